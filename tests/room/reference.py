"""The CPU reference of the GPU's per-pixel pin depth
(:meth:`puppet.render.compositor.Compositor.pin_depth`, what the dressing room's tuck-in
reads): at each pixel centre, the depth of the front-most layer whose texture is not
clear there, NaN where no layer shows.

Each layer's triangles are filled with their index at the pixel centres they hold
(:func:`triangle_ids`, as the GPU rasterises; where a mesh folds over itself the later
triangle holds the pixel), then the depth of every covered pixel is interpolated in its
triangle from the barycentric coordinates of the pixel centre, and the pixel is kept
where the layer's texture at the matching rest point (nearest texel) has alpha > 0. A
garment's depth is its front-most layer's pin depth (its stacking rank taken off), grown
by one pixel over the soft edge (:func:`front_depth`).
"""
from __future__ import annotations

import numpy as np

from puppet.room.depth import grow

#: Candidate pixels tested at once by :func:`triangle_ids` (bounds its memory: ~100 MB).
CHUNK = 1 << 20
#: Slack of the inside test (barycentric units): a centre on an edge is inside.
EPS = 1e-9


def layer_depth(deformed: np.ndarray, rest: np.ndarray, triangles: np.ndarray, depth: np.ndarray,
                image: np.ndarray, offset, size: tuple[int, int]) -> np.ndarray:
    """(H, W) float64 depth of one posed layer over a ``size`` = (W, H) frame; NaN where
    the layer does not show.

    Parameters
    ----------
    deformed, rest : (n, 2) posed and rest vertex positions, canvas pixels.
    triangles : (m, 3) vertex indices.
    depth : (n,) per-vertex depth.
    image : (h, w, 4) the layer's texture, its (0, 0) at ``offset`` in rest canvas pixels.
    """
    w, h = size
    ids = triangle_ids(deformed, triangles, size)
    out = np.full((h, w), np.nan)
    y, x = np.nonzero(ids >= 0)
    if not len(y):
        return out
    tri = np.asarray(triangles, np.int64).reshape(-1, 3)[ids[y, x]]
    bary = _barycentric(np.asarray(deformed, np.float64)[tri], np.stack([x + 0.5, y + 0.5], axis=1))
    at = np.einsum("kj,kjd->kd", bary, np.asarray(rest, np.float64)[tri]) - np.asarray(offset, np.float64)
    th, tw = image.shape[:2]
    u = np.clip(np.floor(at[:, 0]), 0, tw - 1).astype(np.int64)
    v = np.clip(np.floor(at[:, 1]), 0, th - 1).astype(np.int64)
    shows = image[v, u, 3] > 0
    d = np.einsum("kj,kj->k", bary, np.asarray(depth, np.float64)[tri])
    out[y[shows], x[shows]] = d[shows]
    return out


def triangle_ids(deformed: np.ndarray, triangles: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(H, W) int32: at each pixel centre (x + 0.5, y + 0.5) of a ``size`` = (W, H) frame,
    the index of the triangle holding it (the later one where triangles overlap: a fold),
    -1 where none does. A centre on an edge belongs to the triangles on both sides.

    Vectorised over the triangles' bounding boxes in chunks of about :data:`CHUNK`
    candidate pixels (no Python loop per triangle)."""
    w, h = size
    ids = np.full((h, w), -1, np.int32)
    P = np.asarray(deformed, np.float64)[np.asarray(triangles, np.int64).reshape(-1, 3)]  # (m, 3, 2)
    if not len(P):
        return ids
    lo = np.clip(np.ceil(P.min(axis=1) - 0.5), 0, [w, h]).astype(np.int64)  # first centre inside the box
    hi = np.clip(np.floor(P.max(axis=1) - 0.5), -1, [w - 1, h - 1]).astype(np.int64)  # last one
    span = np.maximum(hi - lo + 1, 0)  # (m, 2) columns and rows
    area = span[:, 0] * span[:, 1]
    # a triangle's signed area: its edge functions are divided by it, so both windings work
    a, b, c = P[:, 0], P[:, 1], P[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    live = np.nonzero((area > 0) & (det != 0))[0]
    ends = np.cumsum(area[live])
    start = 0
    while start < len(live):
        stop = int(np.searchsorted(ends, (ends[start - 1] if start else 0) + CHUNK, side="right"))
        stop = max(stop, start + 1)
        t = live[start:stop]
        n = area[t]
        tri = np.repeat(t, n)
        k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)  # index inside its box
        cols = span[tri, 0]
        x = lo[tri, 0] + k % cols
        y = lo[tri, 1] + k // cols
        px, py = x + 0.5, y + 0.5
        A, B, C, D = a[tri], b[tri], c[tri], det[tri]
        l1 = ((px - A[:, 0]) * (C[:, 1] - A[:, 1]) - (C[:, 0] - A[:, 0]) * (py - A[:, 1])) / D
        l2 = ((B[:, 0] - A[:, 0]) * (py - A[:, 1]) - (px - A[:, 0]) * (B[:, 1] - A[:, 1])) / D
        inside = (l1 >= -EPS) & (l2 >= -EPS) & (l1 + l2 <= 1.0 + EPS)
        np.maximum.at(ids, (y[inside], x[inside]), tri[inside].astype(np.int32))  # overlaps: the later triangle
        start = stop
    return ids


def _barycentric(corners: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(k, 3) barycentric coordinates of points ``p`` (k, 2) in triangles ``corners``
    (k, 3, 2); a degenerate triangle gives its first corner."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    ok = det != 0
    safe = np.where(ok, det, 1.0)
    l1 = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1])) / safe
    l2 = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (p[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / safe
    l1, l2 = np.where(ok, l1, 0.0), np.where(ok, l2, 0.0)
    return np.stack([1.0 - l1 - l2, l1, l2], axis=1)


def front_depth(per_layer, orders) -> np.ndarray:
    """The depth the pins carry at each pixel: of several (H, W) layers' pin depths, that
    of the front-most layer there (the largest stacking rank ``orders`` + pin depth, as the
    compositor orders them), so that two garments compare by their pins alone; NaN where
    no layer shows; then :func:`grow`."""
    stack = np.stack(list(per_layer))
    full = np.where(np.isnan(stack), -np.inf, stack + np.asarray(orders, np.float64)[:, None, None])
    front = np.take_along_axis(np.where(np.isnan(stack), -np.inf, stack), full.argmax(axis=0)[None], axis=0)[0]
    return grow(front)
