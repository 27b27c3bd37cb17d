"""A mask's skeleton and the points worth pinning on it: end points and junctions.

``auto_pins(mask)`` is what ``puppet init --pins auto`` uses: per connected component
of the mask (large enough), the mask is smoothed a little, thinned (Zhang-Suen, OpenCV
contrib), short spurs that come from a bumpy outline are pruned, and the skeleton's end
points (limbs, head, tail) and junctions (where limbs meet the body) become pins. Each
pin is moved to the nearest pixel centre that lies well inside the mask, pins closer
than a minimum spacing are merged (junction clusters become one joint), and at most
``max_pins`` are kept (farthest-point order, so the extremities survive).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_N8 = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]
_RING = [(-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1)]  # N, NE, E, ... NW


@dataclass
class AutoPin:
    """A pin found on a mask: ``name`` (``end1``, ``joint1``, ``centre1``), ``kind``
    (``end``, ``joint``, ``centre``), ``at`` = (x, y) pixel centre in image pixels."""

    name: str
    kind: str
    at: tuple[float, float]


def distance_inside(mask: np.ndarray) -> np.ndarray:
    """(h, w) float32: Euclidean distance from each mask pixel's centre to the centre of
    the nearest pixel outside the mask (the image border counts as outside); 0 off the mask."""
    import cv2

    pad = np.pad(mask.astype(np.uint8), 1)
    return cv2.distanceTransform(pad, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]


def neighbours(skel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per skeleton pixel: the number of 8-neighbours on the skeleton and the crossing
    number (0 -> 1 transitions going once round the 8 neighbours), both (h, w) int, 0
    off the skeleton. Crossing number 1 is an end point, 3 or more a junction (a step of
    a staircase line has three neighbours but crossing number 2)."""
    p = np.pad(skel.astype(np.int32), 1)
    h, w = skel.shape
    ring = [p[1 + di:1 + di + h, 1 + dj:1 + dj + w] for di, dj in _RING]
    deg = sum(ring)
    cross = sum((ring[k] == 0) & (ring[(k + 1) % 8] == 1) for k in range(8)).astype(np.int32)
    return np.where(skel, deg, 0), np.where(skel, cross, 0)


def thin(mask: np.ndarray) -> np.ndarray:
    """(h, w) bool one-pixel-wide skeleton of a bool mask (Zhang-Suen thinning). The
    mask is padded first: OpenCV's thinning never removes a pixel on the image's edge,
    and a layer cropped to its pixels touches every edge (a full rectangle stayed whole,
    every edge pixel an end point)."""
    import cv2

    img = np.pad(mask.astype(np.uint8) * 255, 1)
    return cv2.ximgproc.thinning(img, thinningType=cv2.ximgproc.THINNING_ZHANGSUEN)[1:-1, 1:-1] > 0


def _label8(a: np.ndarray) -> tuple[np.ndarray, int]:
    from scipy import ndimage

    return ndimage.label(a, structure=np.ones((3, 3), bool))


def _prune_once(skel: np.ndarray, radius: np.ndarray, extra: float) -> bool:
    """Remove spurs (branches from an end point to a junction shorter than 1.5 times
    the local radius at the junction plus ``extra``) in place; True if any was removed.
    A junction keeps its longest branch when all its branches are spurs."""
    from scipy import ndimage

    deg, cross = neighbours(skel)
    junction = skel & (cross >= 3)
    if not junction.any():
        return False
    area = ndimage.binary_dilation(junction, np.ones((3, 3), bool)) & skel
    jlab, nj = _label8(area)
    blab, nb = _label8(skel & ~area)
    length = np.bincount(blab.ravel(), minlength=nb + 1)
    ends = np.bincount(blab[skel & (cross <= 1)], minlength=nb + 1)
    ii, jj = np.nonzero(blab)
    jp = np.pad(jlab, 1)
    pairs = np.concatenate([np.stack([blab[ii, jj], jp[1 + ii + di, 1 + jj + dj]], 1) for di, dj in _N8])
    pairs = np.unique(pairs[pairs[:, 1] > 0], axis=0)  # (branch, junction) that touch
    r = np.zeros(nj + 1)
    np.maximum.at(r, jlab[area], radius[area])
    touches = np.bincount(pairs[:, 0], minlength=nb + 1)
    spurs: dict[int, list[int]] = {}
    for b, c in pairs:
        if ends[b] > 0 and touches[b] == 1 and length[b] < 1.5 * r[c] + extra:
            spurs.setdefault(int(c), []).append(int(b))
    per_junction = np.bincount(pairs[:, 1], minlength=nj + 1)
    drop = []
    for c, bs in spurs.items():
        if len(bs) == per_junction[c]:  # every branch of this junction is a spur: keep the longest
            bs = sorted(bs, key=lambda b: length[b])[:-1]
        drop += bs
    if not drop:
        return False
    skel[np.isin(blab, drop)] = False
    return True


def skeleton(mask: np.ndarray, *, sigma: float = 1.0, extra: float = 3.0, rounds: int = 8) -> np.ndarray:
    """(h, w) bool pruned skeleton of one connected bool mask.

    The mask is smoothed (Gaussian, ``sigma`` px, threshold at one half, never grown),
    thinned, and spurs are pruned (see :func:`_prune_once`) for up to ``rounds`` rounds,
    thinning again after each (a removed spur can leave a small blob at its junction).
    """
    import cv2

    m = mask.astype(np.float32)
    if sigma > 0:
        k = int(2 * round(3 * sigma) + 1)
        smooth = (cv2.GaussianBlur(m, (k, k), sigma, borderType=cv2.BORDER_CONSTANT) >= 0.5) & mask
        if smooth.any():
            m = smooth.astype(np.float32)
    skel = thin(m > 0)
    radius = distance_inside(m > 0)
    for _ in range(rounds):
        if not _prune_once(skel, radius, extra):
            break
        skel = thin(skel)
    return skel


def skeleton_points(skel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """End points and junctions of a skeleton, as (n, 2) int arrays of (row, col).

    A junction cluster (adjacent pixels with three or more neighbours) counts once, at
    its pixel nearest the cluster's centroid. A lone pixel counts as an end point.
    """
    _, cross = neighbours(skel)
    ends = np.argwhere(skel & (cross <= 1))
    lab, n = _label8(cross >= 3)
    joints = []
    for c in range(1, n + 1):
        pts = np.argwhere(lab == c)
        centre = pts.mean(axis=0)
        joints.append(pts[np.argmin(((pts - centre) ** 2).sum(1))])
    return ends.reshape(-1, 2), np.array(joints, np.int64).reshape(-1, 2)


def _inward(points: np.ndarray, deep: np.ndarray) -> np.ndarray:
    """Each (row, col) moved to the nearest pixel of ``deep`` (bool, not empty)."""
    from scipy import ndimage

    _, (ri, ci) = ndimage.distance_transform_edt(~deep, return_indices=True)
    return np.stack([ri[points[:, 0], points[:, 1]], ci[points[:, 0], points[:, 1]]], axis=1)


#: Components are thinned at most this many pixels wide or tall (larger ones are scaled down first).
SKELETON_SIDE = 256


def _skeleton_points_scaled(comp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """End points and junctions (row, col) of one component's skeleton in its own grid;
    the skeleton is computed on a copy scaled to at most :data:`SKELETON_SIDE` px."""
    import cv2

    h, w = comp.shape
    s = max(1.0, max(h, w) / SKELETON_SIDE)
    small = comp
    if s > 1:
        size = (max(1, round(w / s)), max(1, round(h / s)))
        small = cv2.resize(comp.astype(np.float32), size, interpolation=cv2.INTER_AREA) >= 0.5
        if not small.any():
            small = comp
            s = 1.0
    area = int(small.sum())
    ends, joints = skeleton_points(skeleton(small, sigma=max(1.0, 0.012 * np.sqrt(area))))
    sy, sx = h / small.shape[0], w / small.shape[1]

    def up(p: np.ndarray) -> np.ndarray:
        r = np.clip(np.floor((p[:, 0] + 0.5) * sy), 0, h - 1)
        c = np.clip(np.floor((p[:, 1] + 0.5) * sx), 0, w - 1)
        return np.stack([r, c], 1).astype(np.int64)
    return up(ends), up(joints)


def _component_candidates(comp: np.ndarray, dist: np.ndarray, margin: float) -> list[tuple[str, np.ndarray, float]]:
    """(kind, (row, col), depth) candidates on one component (cropped arrays)."""
    ends, joints = _skeleton_points_scaled(comp)
    deep = comp & (dist >= margin + 1.0)
    if not deep.any():  # a thin part: its deepest pixels
        deep = comp & (dist >= dist[comp].max())
    out = []
    for kind, pts in (("end", ends), ("joint", joints)):
        if len(pts):
            pts = _inward(pts, deep)
            out += [(kind, p, float(dist[p[0], p[1]])) for p in pts]
    if not out:
        i, j = np.unravel_index(np.argmax(np.where(deep, dist, -1)), dist.shape)
        out.append(("centre", np.array([i, j]), float(dist[i, j])))
    return out


def _merge(cands: list[tuple[str, np.ndarray, float]], spacing: float) -> list[tuple[str, np.ndarray, float]]:
    """Greedy: end points first, then joints by depth; drop a point closer than
    ``spacing`` (or than a kept joint's radius) to a kept one. Each point is compared
    with every kept one at once (a blob can give hundreds of candidates)."""
    order = sorted(cands, key=lambda c: (c[0] != "end", -c[2]))
    at = np.empty((len(order), 2))
    reach = np.empty(len(order))  # a kept point's own reach: its radius when a joint
    kept: list[tuple[str, np.ndarray, float]] = []
    for c in order:
        m = len(kept)
        own = c[2] if c[0] == "joint" else 0.0
        if m:
            d = np.hypot(at[:m, 0] - c[1][0], at[:m, 1] - c[1][1])
            if (d < np.maximum(np.maximum(reach[:m], own), spacing)).any():
                continue
        at[m], reach[m] = c[1], own
        kept.append(c)
    return kept


def _farthest(points: np.ndarray, k: int) -> list[int]:
    """Indices of ``k`` points by farthest-point sampling from the one farthest from the mean."""
    if len(points) <= k:
        return list(range(len(points)))
    first = int(np.argmax(((points - points.mean(0)) ** 2).sum(1)))
    chosen = [first]
    d = np.hypot(*(points - points[first]).T)
    while len(chosen) < k:
        nxt = int(np.argmax(d))
        chosen.append(nxt)
        d = np.minimum(d, np.hypot(*(points - points[nxt]).T))
    return chosen


def auto_pins(mask: np.ndarray, *, max_pins: int = 16, margin: float = 2.0,
              min_area: int = 64) -> list[AutoPin]:
    """Pins at the skeleton's end points and junctions of a mask.

    Parameters
    ----------
    mask : (h, w) bool.
    max_pins : most pins returned (over all components).
    margin : each pin's pixel has at least ``margin`` whole mask pixels between it and
        the outside (where the component is thick enough; else its deepest pixel).
    min_area : components smaller than this, or than 1 % of the largest, get no pins.

    Returns
    -------
    list of AutoPin, named ``end1..``, ``joint1..``, ``centre1..`` in reading order
    (top to bottom, then left to right); ``at`` = (col + 0.5, row + 0.5), a pixel centre.
    """
    import cv2

    mask = np.asarray(mask, bool)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return []
    areas = stats[1:, cv2.CC_STAT_AREA]
    big = [c + 1 for c in np.argsort(-areas) if areas[c] >= max(min_area, 0.01 * areas.max())]
    cands = []
    h, w = mask.shape
    for c in big:
        x, y, bw, bh = (int(v) for v in stats[c, :4])
        y0, y1, x0, x1 = max(y - 1, 0), min(y + bh + 1, h), max(x - 1, 0), min(x + bw + 1, w)
        comp = lab[y0:y1, x0:x1] == c
        dist = distance_inside(comp)
        spacing = max(4.0, 0.08 * np.sqrt(stats[c, cv2.CC_STAT_AREA]))
        for kind, p, depth in _merge(_component_candidates(comp, dist, margin), spacing):
            cands.append((kind, np.array([p[0] + y0, p[1] + x0]), depth))
    if not cands:
        return []
    pts = np.array([c[1] for c in cands], float)
    keep = sorted(_farthest(pts, max_pins), key=lambda i: (cands[i][1][0], cands[i][1][1]))
    counts: dict[str, int] = {}
    pins = []
    for i in keep:
        kind, (r, col), _ = cands[i]
        counts[kind] = counts.get(kind, 0) + 1
        pins.append(AutoPin(f"{kind}{counts[kind]}", kind, (float(col) + 0.5, float(r) + 0.5)))
    return pins
