"""Per-cell settings of a group's ARAP energy: each vertex's mode (its layer's
``deformer.mode`` or the scene's) and its painted stiffness (grey 0..255) from the
layer's stiffness image, starch pins and link polygons.

The grey g of a cell becomes its energy weight ``k = 100 ** (g / 255)`` and the fraction
``g / 255`` of its energy that is rigid whatever the mode (:mod:`puppet.deform.modes`).
"""
from __future__ import annotations

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import load_rgba

#: Reach of a starch pin without a ``radius``, px.
STARCH_RADIUS = 40.0


def stiffness_image(data, L, im) -> np.ndarray | None:
    """Layer ``L``'s painted stiffness as grey levels (h, w) float aligned with its image
    ``im`` (a :class:`puppet.scene.rig.build.LayerImage`), or None. Grey of the colour
    (Pillow's ``convert("L")`` weights) times alpha / 255: transparent is unpainted."""
    if L.stiffness is None:
        return None
    path = f"layers[{L.index}].stiffness.file"
    rgba = load_rgba(L.stiffness, scene_file=data.file, json_path=path)
    if rgba.shape[:2] != im.rgba.shape[:2]:
        h, w = im.rgba.shape[:2]
        raise SceneError(f"stiffness image is {rgba.shape[1]}x{rgba.shape[0]} but the layer image is {w}x{h}",
                         file=data.file, path=path)
    c = rgba.astype(np.int64)
    grey = (19595 * c[..., 0] + 38470 * c[..., 1] + 7471 * c[..., 2] + 32768) >> 16
    return grey * (c[..., 3] / 255.0)


def _sample(grey: np.ndarray, offset, V: np.ndarray) -> np.ndarray:
    """Grey at canvas points V (n, 2): the pixel under each point, clamped to the image."""
    h, w = grey.shape
    j = np.clip(np.floor(V[:, 0] - offset[0]).astype(np.int64), 0, w - 1)
    i = np.clip(np.floor(V[:, 1] - offset[1]).astype(np.int64), 0, h - 1)
    return grey[i, j].astype(np.float64)


def _reach(V: np.ndarray, at, r: float) -> np.ndarray:
    """Distance of points V (n, 2) from ``at`` as a fraction of ``r``, capped at 1: (n,).

    Every radius the format allows (0 < r <= 1e4, however small) gives no warning: the
    distance is capped at ``r`` before the division, so the quotient lies in [0, 1] and
    ``r * r`` (which underflows to 0 for r below 1e-154) is never formed."""
    d = np.hypot(V[:, 0] - at[0], V[:, 1] - at[1])
    return np.minimum(d, r) / r


def _in_polygon(P: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon of points V (n, 2) in polygon P (p, 2); (n,) bool."""
    x, y = V[:, 0][:, None], V[:, 1][:, None]
    x0, y0 = P[:, 0][None], P[:, 1][None]
    x1, y1 = np.roll(P[:, 0], -1)[None], np.roll(P[:, 1], -1)[None]
    cross = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return ((cross & (x < xs)).sum(axis=1) % 2).astype(bool)


def layer_grey(data, k: int, im, V: np.ndarray) -> np.ndarray | None:
    """Painted stiffness (grey 0..255) of layer ``k``'s mesh vertices V (n, 2), or None
    when nothing stiffens the layer."""
    L = data.layers[k]
    out = None
    img = stiffness_image(data, L, im)
    if img is not None:
        out = _sample(img, im.offset, V)
    for p in data.pins:
        if p.kind == "starch" and p.layer == L.name:
            if not im.contains(p.at):
                i = data.pins.index(p)
                raise SceneError(f"starch pin {p.name!r} at ({p.at[0]:g}, {p.at[1]:g}) is outside the mask of "
                                 f"layer {L.name!r}", file=data.file, path=f"pins[{i}].at")
            g = 255.0 * (1.0 - _reach(V, p.at, p.radius or STARCH_RADIUS) ** 2) ** 2  # smooth bump, 255 at the pin
            out = g if out is None else np.maximum(out, g)
    for link in data.links:
        if L.name in link.layers:
            for P in link.polygons:
                g = np.where(_in_polygon(P, V), 255.0, 0.0)
                out = g if out is None else np.maximum(out, g)
    return out


def group_cells(data, images, g, meshes) -> tuple[np.ndarray | None, list[str]]:
    """Grey (n,) or None and mode per vertex of group ``g``; a vertex shared by two layers
    takes the larger grey and the later layer's mode."""
    n = len(g.mesh.V)
    grey = None
    modes = [data.deformer.mode] * n
    for li, k in enumerate(g.layers):
        idx = g.mesh.maps[li]
        mode = data.layers[k].mode
        if mode is not None:
            for v in idx:
                modes[v] = mode
        gk = layer_grey(data, k, images[k], meshes[k].V)
        if gk is not None:
            if grey is None:
                grey = np.zeros(n)
            np.maximum.at(grey, idx, gk)
    return grey, modes
