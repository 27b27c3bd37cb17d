"""What the compositor draws: one textured, deformed mesh per layer, and the numpy
helpers that prepare it (premultiplied textures, depth normalisation, mesh edges)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: A fragment counts as peeled when its window depth is <= previous peel + this.
EPSILON = 2.0 ** -18
#: Window-depth bias per list position, so exact ties put the later layer in front.
TIE_BIAS = 4 * EPSILON


@dataclass
class DrawLayer:
    """One textured mesh to composite.

    Attributes
    ----------
    key : str
        Stable name; the uploaded texture and buffers are cached under it across frames.
    image : ndarray, shape (h, w, 4), uint8
        Straight-alpha RGBA texture. Treat it as immutable: the texture is re-uploaded
        only when a different array (or shape) is passed under the same key.
    offset : tuple of float
        Canvas position of the image's top-left corner.
    rest : ndarray, shape (n, 2)
        Rest positions, canvas pixels: texture coordinate = (rest - offset) / (w, h).
    deformed : ndarray, shape (n, 2)
        Drawn positions, canvas pixels (x right, y down, origin top-left).
    triangles : ndarray, shape (m, 3), int
        Vertex indices.
    depth : ndarray, shape (n,)
        Per-vertex depth, higher = in front, any real range.
    """

    key: str
    image: np.ndarray
    offset: tuple[float, float]
    rest: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    depth: np.ndarray


def premultiply(image: np.ndarray) -> np.ndarray:
    """Premultiply straight RGBA uint8, rounding to nearest: ``round(c * a / 255)``."""
    wide = image.astype(np.uint16)
    out = np.empty_like(image)
    out[..., :3] = (wide[..., :3] * wide[..., 3:] + 127) // 255
    out[..., 3] = image[..., 3]
    return out


def window_depths(layers: list[DrawLayer]) -> list[np.ndarray]:
    """Per-layer window depths in (0, 1), 0 = nearest, float32.

    The frame's depth range [lo, hi] is widened by a margin of max(5 % of the range,
    0.5) on each side; depth d maps to (hi - d) / (hi - lo) minus ``i * TIE_BIAS`` for
    the layer at list position i.
    """
    if not layers:
        return []
    lo = min(float(np.min(layer.depth)) for layer in layers)
    hi = max(float(np.max(layer.depth)) for layer in layers)
    margin = max(0.05 * (hi - lo), 0.5)
    lo, hi = lo - margin, hi + margin
    out = []
    for i, layer in enumerate(layers):
        z = (hi - np.asarray(layer.depth, np.float64)) / (hi - lo) - i * TIE_BIAS
        out.append(np.clip(z, 4 * EPSILON, 1.0 - 4 * EPSILON).astype(np.float32))
    return out


def mesh_edges(triangles: np.ndarray) -> np.ndarray:
    """Unique undirected edges, shape (k, 2) int32, of triangles (m, 3)."""
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    n = int(t.max(initial=0)) + 1
    keys = np.unique(e[:, 0] * n + e[:, 1])
    return np.stack([keys // n, keys % n], axis=1).astype(np.int32)


def _check_background(background) -> np.ndarray:
    """Background as an (H, W, 4) uint8 image; a colour becomes a 1x1 image."""
    if isinstance(background, np.ndarray) and background.ndim == 3:
        if background.shape[2] != 4 or background.dtype != np.uint8:
            raise ValueError("a background image must be (H, W, 4) uint8")
        return background
    rgba = np.asarray(background, np.float64).reshape(-1)
    if rgba.shape != (4,) or not np.all((rgba >= 0) & (rgba <= 255)):
        raise ValueError(f"background colour must be 4 values in 0..255, got {background}")
    return np.rint(rgba).astype(np.uint8).reshape(1, 1, 4)


def _check_layer(layer: DrawLayer) -> None:
    img, n, tri = layer.image, len(layer.deformed), np.asarray(layer.triangles)
    problem = (
        "image must be (h, w, 4) uint8" if img.ndim != 3 or img.shape[2] != 4
        or img.dtype != np.uint8 else
        "rest, deformed (n, 2) and depth (n,) must agree" if np.shape(layer.rest) != (n, 2)
        or np.shape(layer.deformed) != (n, 2) or np.shape(layer.depth) != (n,) else
        f"triangles must be (m, 3) indices below {n}" if tri.ndim != 2 or tri.shape[1] != 3
        or (tri.size and (tri.min() < 0 or tri.max() >= n)) else
        "depth and deformed must be finite" if not (np.all(np.isfinite(layer.depth))
                                                  and np.all(np.isfinite(layer.deformed)))
        else None)
    if problem:
        raise ValueError(f"layer {layer.key!r}: {problem}")
