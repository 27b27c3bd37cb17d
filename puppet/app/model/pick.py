"""What is under the cursor: the top-most layer (by interpolated depth, through the shown
deformed meshes) and the pin markers. Plain numpy over posed layers; no GL."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Marker:
    """A pin as shown: ``kind`` is ``interior``, ``exterior`` (an exterior pin) or
    ``auto`` (an automatic exterior point, movable in poses only)."""

    name: str
    kind: str
    layer: int
    xy: tuple[float, float]  # canvas position in the shown pose


@dataclass(frozen=True)
class Hit:
    """A point on a layer: its index, the matching rest (unposed) canvas point, its depth."""

    layer: int
    rest: tuple[float, float]
    depth: float


def markers(data, layers) -> list[Marker]:
    """Every pin and exterior point of the scene where the shown pose puts it.

    Parameters
    ----------
    data : SceneData
    layers : list of LayerResult
        The shown pose (scene layer order).
    """
    index = {L.name: k for k, L in enumerate(data.layers)}
    out = []
    kinds = {p.name: p.kind for p in data.pins}
    for p in data.pins:
        k = index.get(p.layer)
        if k is None or k >= len(layers):
            continue
        r = layers[k]
        if p.kind == "interior" and p.name in r.pins:
            xy = r.deformed[r.pins[p.name]]
        elif p.kind == "starch" and (s := shown_point(r, p.at)) is not None:  # carried by the mesh
            xy = s
        elif p.name in r.exterior:
            xy = r.exterior[p.name]
        else:
            xy = p.at
        out.append(Marker(p.name, p.kind, k, (float(xy[0]), float(xy[1]))))
    for k, r in enumerate(layers):
        for name, xy in r.exterior.items():
            if name not in kinds:
                out.append(Marker(name, "auto", k, (float(xy[0]), float(xy[1]))))
    return out


#: Markers are drawn full size where their neighbours are at least this far apart on
#: screen (window px); closer, they shrink in proportion, down to MIN_MARKER_SCALE.
MARKER_SPACING = 22.0
MIN_MARKER_SCALE = 0.4


def spacing(points: np.ndarray) -> float:
    """Median distance from each of ``points`` (n, 2) to its nearest other point (inf for
    fewer than two)."""
    P = np.asarray(points, float).reshape(-1, 2)
    if len(P) < 2:
        return math.inf
    nearest = np.empty(len(P))
    for i0 in range(0, len(P), 256):  # blocks: n^2 / 256 distances at a time
        d = np.hypot(*(P[i0:i0 + 256, None, :] - P[None, :, :]).transpose(2, 0, 1))
        d[np.arange(len(d)), np.arange(i0, i0 + len(d))] = math.inf
        nearest[i0:i0 + len(d)] = d.min(axis=1)
    return float(np.median(nearest))


def marker_scale(canvas_spacing: float, view_scale: float) -> float:
    """How big markers are drawn (a fraction of full size) when their median spacing on
    the canvas is ``canvas_spacing`` px and the view shows a canvas px as ``view_scale``
    window px: a big character fitted to a small window keeps its art visible between its
    pins instead of being covered by them."""
    return float(np.clip(canvas_spacing * view_scale / MARKER_SPACING, MIN_MARKER_SCALE, 1.0))


def marker_at(found: list[Marker], screen_points: np.ndarray, cursor, radius: float = 9.0) -> Marker | None:
    """The marker nearest to ``cursor`` (window pixels) within ``radius``; ``screen_points``
    (n, 2) are the markers' window positions. Interior and exterior pins win over
    automatic points at the same distance."""
    if not found:
        return None
    d = np.hypot(*(np.asarray(screen_points, float) - np.asarray(cursor, float)).T)
    d = d + np.array([0.5 if m.kind == "auto" else 0.0 for m in found])
    i = int(np.argmin(d))
    return found[i] if d[i] <= radius else None


def layer_at(layers, images, xy, hidden=()) -> Hit | None:
    """The front-most layer whose shown pixels cover canvas point ``xy``.

    Each layer's deformed triangles are searched for ``xy``; the barycentric weights give
    the rest point (checked against the layer's mask) and the interpolated depth, the
    same depth the compositor draws with, so the answer is the layer seen there.

    Parameters
    ----------
    layers : list of LayerResult
    images : list of LayerImage
        ``.contains(xy)`` tells whether a rest canvas point is on the layer's mask.
    xy : (2,) canvas point
    hidden : container of int
        Layer indices to skip (hidden in the app).
    """
    p = np.asarray(xy, float)
    best: Hit | None = None
    for k, r in enumerate(layers):
        if k in hidden or not len(r.triangles):
            continue
        U = np.asarray(r.deformed, float)
        lo, hi = U.min(axis=0), U.max(axis=0)
        if np.any(p < lo) or np.any(p > hi):
            continue
        w, t = _barycentric(U, np.asarray(r.triangles), p)
        if t is None:
            continue
        tri = r.triangles[t]
        rest = w @ np.asarray(r.rest, float)[tri]
        depth = float(w @ np.asarray(r.depth, float)[tri])
        if not images[k].contains(rest):
            continue
        if best is None or depth >= best.depth:
            best = Hit(k, (float(rest[0]), float(rest[1])), depth)
    return best


def rest_point(layer, xy) -> tuple[float, float] | None:
    """The rest canvas point that ``layer`` (a LayerResult) shows at canvas point ``xy``."""
    w, t = _barycentric(np.asarray(layer.deformed, float), np.asarray(layer.triangles), np.asarray(xy, float))
    if t is None:
        return None
    rest = w @ np.asarray(layer.rest, float)[layer.triangles[t]]
    return (float(rest[0]), float(rest[1]))


def shown_point(layer, rest) -> np.ndarray | None:
    """Where ``layer`` (a LayerResult) shows rest canvas point ``rest`` (2,): through the
    triangle that holds it, or a point on the outline by its nearest vertex (within 3
    px); None when it is off the mesh."""
    F = np.asarray(layer.triangles)
    V = np.asarray(layer.rest, float)
    w, t = _barycentric(V, F, np.asarray(rest, float))
    if t is None:
        d = np.hypot(*(V - rest).T)
        i = int(np.argmin(d))
        return np.asarray(layer.deformed[i], float) if d[i] < 3.0 else None
    return w @ np.asarray(layer.deformed, float)[F[t]]


def _barycentric(U: np.ndarray, F: np.ndarray, p: np.ndarray):
    """Barycentric weights (3,) of ``p`` in the first triangle of (U, F) containing it, and
    that triangle's index; (None, None) when none does."""
    a, b, c = U[F[:, 0]], U[F[:, 1]], U[F[:, 2]]
    v0, v1, v2 = b - a, c - a, p - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    ok = np.abs(den) > 1e-12
    den = np.where(ok, den, 1.0)
    s = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
    t = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    eps = 1e-9
    inside = ok & (s >= -eps) & (t >= -eps) & (s + t <= 1 + eps)
    idx = np.flatnonzero(inside)
    if not len(idx):
        return None, None
    i = int(idx[0])
    return np.array([1 - s[i] - t[i], s[i], t[i]]), i
