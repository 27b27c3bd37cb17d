"""Mask -> closed contours (outer rings and holes) -> simplified, resampled polygons."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Region:
    """One connected component of a mask: an outer ring and its holes.

    Rings are (n, 2) float arrays of canvas coordinates, not closed (last != first).
    """

    outer: np.ndarray
    holes: list[np.ndarray] = field(default_factory=list)


def ring_area(P: np.ndarray) -> float:
    """Signed area of a closed ring (shoelace; positive = counter-clockwise in y-up axes)."""
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def fill_small_holes(m: np.ndarray, min_hole: int) -> np.ndarray:
    """Fill background components that do not touch the border and have fewer than
    ``min_hole`` pixels (uint8 0/1 in, out)."""
    import cv2

    if min_hole <= 0:
        return m
    n, lab, stats, _ = cv2.connectedComponentsWithStats((m == 0).astype(np.uint8), connectivity=4)
    h, w = m.shape
    out = m.copy()
    for k in range(1, n):
        x, y, bw, bh, area = stats[k]
        touches = x == 0 or y == 0 or x + bw == w or y + bh == h
        if not touches and area < min_hole:
            out[lab == k] = 1
    return out


def mask_regions(mask: np.ndarray, offset=(0.0, 0.0), *, grow: int = 1, min_hole: int = 16) -> list[Region]:
    """Outer contours and holes of every component of a mask.

    The mask is first grown by ``grow`` pixels so that the contour, which runs through
    the centres of boundary pixels, encloses every pixel of the mask (the texture's own
    alpha then gives the exact, anti-aliased edge). Holes smaller than ``min_hole``
    pixels are filled: they are pixel noise (often made by the growing, where a narrow
    notch pinches shut), and their rings would touch the outer ring.

    Parameters
    ----------
    mask : (h, w) bool.
    offset : canvas position of the mask's top-left corner.

    Returns
    -------
    list of Region, in canvas coordinates (pixel (i, j) has its centre at (j+0.5, i+0.5)).
    """
    import cv2

    m = mask.astype(np.uint8)
    # work on the mask's bounding box with a background margin wider than the growing:
    # the same rings (a background component touches the crop's border exactly when it
    # reaches the mask's outside), at a fraction of the cost for a part on a big canvas
    x, y, w, h = cv2.boundingRect(m)
    if w == 0:
        return []
    H, W = m.shape
    pad = max(grow, 0) + 1
    x0, y0 = max(x - pad, 0), max(y - pad, 0)
    m = m[y0:y + h + pad, x0:x + w + pad]
    # where the crop meets the image's edge, background beyond it: the growing then goes
    # past the edge, and the rings are clamped to the edge below, so a mask pixel on the
    # image's last row or column has its centre inside the mesh (not on its boundary,
    # where the rasteriser's fill rule drops the bottom and right edges)
    before = (y0 - (y - pad), x0 - (x - pad))
    m = np.pad(m, ((before[0], max(y + h + pad - H, 0)), (before[1], max(x + w + pad - W, 0))))
    x0, y0 = x0 - before[1], y0 - before[0]
    offset = (offset[0] + x0, offset[1] + y0)
    lo = np.asarray(offset, np.float64) - (x0, y0)
    hi = lo + (W, H)
    if grow > 0:
        k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow + 1, 2 * grow + 1))
        m = cv2.dilate(m, k)
    m = fill_small_holes(m, min_hole)
    # pad so that contours touching the image border are still closed curves
    m = np.pad(m, 1)
    contours, hierarchy = cv2.findContours(m, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hierarchy is None:
        return []
    hierarchy = hierarchy[0]
    shift = np.asarray(offset, np.float64) + 0.5 - 1.0  # centre of pixel, minus padding

    def ring(c):
        return _clamped(c[:, 0, :].astype(np.float64) + shift, lo, hi)

    regions: dict[int, Region] = {}
    for i, c in enumerate(contours):
        parent = hierarchy[i][3]
        if parent < 0:
            regions[i] = Region(ring(c))
    for i, c in enumerate(contours):
        parent = hierarchy[i][3]
        if parent >= 0 and parent in regions:
            regions[parent].holes.append(ring(c))
    return list(regions.values())


def _clamped(P: np.ndarray, lo, hi) -> np.ndarray:
    """Ring ``P`` clamped into the box [lo, hi] (the image's edges), without the repeated
    points clamping makes; unchanged where it lies inside."""
    Q = np.clip(P, lo, hi)
    if (Q == P).all():
        return P
    keep = np.any(Q != np.roll(Q, 1, axis=0), axis=1)
    return Q[keep] if keep.sum() >= 3 else Q


def simplify_ring(P: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas-Peucker simplification of a closed ring (OpenCV's approxPolyDP)."""
    import cv2

    if tolerance <= 0 or len(P) < 4:
        return P
    Q = cv2.approxPolyDP(P.astype(np.float32).reshape(-1, 1, 2), float(tolerance), True)
    Q = Q[:, 0, :].astype(np.float64)
    return Q if len(Q) >= 3 else P


def keep_outside(P: np.ndarray, Q: np.ndarray, *, hole: bool, limit: float = 0.45) -> np.ndarray:
    """``Q``, a simplification of ring ``P`` made of some of its points in order, with
    points of ``P`` put back wherever ``Q`` cuts into the region by more than ``limit``
    px (the farthest first, as Douglas-Peucker would, on that side only). ``hole``: the
    region lies outside ``P``.

    Douglas-Peucker strays up to its tolerance to either side. The contour of
    :func:`mask_regions` runs a pixel outside the mask's pixel centres, half a pixel where
    it is clamped to the image's edge, so a 1 px tolerance that cuts inwards left the
    centres of edge pixels outside the mesh: they did not render (the last column of an
    anti-aliased ellipse on its layer's edge, 36 pixels of psd-tools' ``masks-2.psd``)."""
    n = len(P)
    if len(Q) < 3 or len(Q) >= n:
        return Q
    where: dict[tuple, list[int]] = {}
    for i, p in enumerate(map(tuple, P)):
        where.setdefault(p, []).append(i)
    kept, last = [], -1
    for q in map(tuple, Q):
        cand = where.get(q)
        if cand is None:
            return Q  # not a subset of P's points: leave it
        after = [i for i in cand if i > last]
        last = after[0] if after else cand[0]
        kept.append(last)
    inside = 1.0 if (ring_area(P) > 0) != hole else -1.0  # the region lies left of each edge (cross > 0)
    stack = [(kept[k], kept[(k + 1) % len(kept)]) for k in range(len(kept))]
    extra = []
    while stack:
        i, j = stack.pop()
        m = (j - i) % n
        if m < 2:
            continue
        between = (i + 1 + np.arange(m - 1)) % n
        a, b = P[i], P[j]
        d = b - a
        L = float(np.hypot(*d))
        if L < 1e-12:
            continue
        cross = (d[0] * (P[between, 1] - a[1]) - d[1] * (P[between, 0] - a[0])) / L
        out = -inside * cross  # > 0: the point lies outside Q's edge, so the edge cuts into the region
        k = int(np.argmax(out))
        if out[k] > limit:
            extra.append(int(between[k]))
            stack += [(i, int(between[k])), (int(between[k]), j)]
    if not extra:
        return Q
    idx = sorted(set(kept) | set(extra), key=lambda t: (t - kept[0]) % n)
    return P[idx]


def resample_ring(P: np.ndarray, max_edge: float) -> np.ndarray:
    """Split every edge of a closed ring longer than ``max_edge`` into equal pieces."""
    Q = np.roll(P, -1, axis=0)
    L = np.linalg.norm(Q - P, axis=1)
    counts = np.maximum(1, np.ceil(L / max_edge - 1e-9).astype(int))
    out = []
    for a, b, n in zip(P, Q, counts):
        t = np.arange(n)[:, None] / n
        out.append(a + t * (b - a))
    return np.concatenate(out, axis=0)


def subdivide_segment(a, b, max_edge: float) -> np.ndarray:
    """Points of the segment a-b split into equal pieces no longer than ``max_edge``."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    n = max(1, int(np.ceil(np.linalg.norm(b - a) / max_edge - 1e-9)))
    t = np.arange(n + 1)[:, None] / n
    return a + t * (b - a)
