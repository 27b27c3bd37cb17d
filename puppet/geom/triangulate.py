"""Constrained quality Delaunay triangulation of mask regions (Shewchuk's Triangle).

Pins become vertices; link segments become constrained edges. Segments are never split
by Triangle (switch ``YY``): we subdivide them ourselves first, so two linked layers get
exactly the same vertices along a shared link segment. The number of triangles is
estimated and bounded (:data:`MAX_TRIANGLES`) before Triangle runs; Triangle is given
no repeated vertices and no outline crossing another (see :mod:`puppet.geom.pslg`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.geom.contour import Region, keep_outside, resample_ring, simplify_ring
from puppet.geom.pslg import clean_pslg, merge_vertices, segment_conflicts

__all__ = ["Mesh", "MAX_TRIANGLES", "MeshTooLarge", "clean_pslg", "edge_length_for_area",
           "estimate_triangles", "orient_and_compact", "signed_areas", "triangulate_regions"]

#: Largest mesh a layer may have (triangles); the estimate is checked before Triangle runs.
MAX_TRIANGLES = 2_000_000


@dataclass
class Mesh:
    """A triangle mesh in canvas coordinates.

    V : (n, 2) float vertices. F : (m, 3) int triangles, counter-clockwise as seen on
    screen (y down), i.e. negative signed area in raw (x, y) coordinates.
    """

    V: np.ndarray
    F: np.ndarray


class MeshTooLarge(ValueError):
    """A ``max_area`` that would make more than ``limit`` triangles (about ``estimate``)."""

    def __init__(self, estimate: int, limit: int, max_area: float, smallest: float):
        self.estimate, self.limit, self.max_area, self.smallest = estimate, limit, max_area, smallest
        super().__init__(f"max_area {max_area:g} px² would make about {estimate:,} triangles (at most "
                         f"{limit:,} in a layer); use max_area >= {smallest:.3g}")


def edge_length_for_area(max_area: float) -> float:
    """Edge length of an equilateral triangle of area ``max_area``."""
    return float(np.sqrt(4.0 * max_area / np.sqrt(3.0)))


def triangles_per_area(min_angle: float) -> float:
    """Triangles Triangle makes per ``max_area`` of region at the quality bound
    ``min_angle`` (measured 1.55 up to 25 degrees, 1.8-2.0 at 34), rounded up."""
    return 1.6 + 0.4 * float(np.clip((min_angle - 25.0) / 9.0, 0.0, 1.0))


def estimate_triangles(area: float, boundary: int, points: int, *, max_area: float,
                       min_angle: float) -> int:
    """Triangles a quality triangulation will have.

    Parameters
    ----------
    area : region area, px². boundary : boundary vertices after resampling.
    points : other fixed vertices (pins, link vertices).

    Returns
    -------
    ``triangles_per_area * area / max_area + boundary + 2 points``: within -10 %..+20 %
    on compact shapes, an overestimate (up to ~3x) on thin ones.
    """
    return int(np.ceil(triangles_per_area(min_angle) * area / max_area + boundary + 2 * points))


def _hole_point(ring: np.ndarray) -> np.ndarray:
    """A point strictly inside a closed ring (centroid of its largest triangle)."""
    import triangle

    n = len(ring)
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    # a ring that pinches (touches itself at a pixel corner) repeats a vertex: Triangle crashes on those
    t = triangle.triangulate(clean_pslg(ring, seg), "pQ")
    T = t["triangles"]
    W = t["vertices"]
    a, b, c = W[T[:, 0]], W[T[:, 1]], W[T[:, 2]]
    area = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    k = int(np.argmax(area))
    return (a[k] + b[k] + c[k]) / 3.0


def _simplified(R: np.ndarray, tolerance: float, hole: bool = False) -> np.ndarray:
    """Douglas-Peucker relative to the first point: exact in OpenCV's float32 for rings
    on the pixel grid, so simplified vertices stay on the grid whatever the offset; never
    cutting more than half a pixel into the region (:func:`keep_outside`)."""
    if not len(R):
        return R
    S = R - R[0]
    return keep_outside(S, simplify_ring(S, tolerance), hole=hole) + R[0]


def _resampled_count(R: np.ndarray, h: float) -> int:
    L = np.linalg.norm(np.roll(R, -1, axis=0) - R, axis=1)
    return int(np.maximum(1, np.ceil(L / h - 1e-9)).sum())


def triangulate_regions(
    regions: list[Region],
    *,
    max_area: float,
    min_angle: float = 25.0,
    simplify: float = 1.0,
    points: np.ndarray | None = None,
    segments: list[np.ndarray] | None = None,
    max_triangles: int = MAX_TRIANGLES,
) -> Mesh:
    """Quality constrained Delaunay triangulation of the regions.

    Rings are simplified, then every edge is split to at most the edge length of a
    ``max_area`` triangle. A simplified ring that crosses or touches another ring or a
    link segment (Douglas-Peucker keeps no topology) is used unsimplified instead.

    Parameters
    ----------
    regions : outer rings and holes (canvas coordinates), from ``mask_regions``.
    max_area : largest triangle area, px^2.
    min_angle : smallest angle Triangle aims for, degrees (at most 34).
    simplify : Douglas-Peucker tolerance for the rings, px.
    points : (p, 2) points that must be vertices (pins).
    segments : polylines (each (s, 2), already subdivided) that must be edges (links).
    max_triangles : limit on the estimated number of triangles.

    Returns
    -------
    Mesh with vertices of unreferenced points removed.

    Raises
    ------
    MeshTooLarge
        Before any triangulation, when :func:`estimate_triangles` exceeds ``max_triangles``.
    """
    import triangle

    h = edge_length_for_area(max_area)
    raw, is_hole = [], []
    for reg in regions:
        for k, ring in enumerate([reg.outer] + list(reg.holes)):
            raw.append(np.asarray(ring, np.float64).reshape(-1, 2))
            is_hole.append(k > 0)
    simple = [_simplified(R, simplify, hole) for R, hole in zip(raw, is_hole)]
    usable = [len(R) >= 3 and abs(_signed(R)) >= 1e-6 for R in simple]
    lines = [np.asarray(S, np.float64).reshape(-1, 2) for S in segments or []]
    pts = np.zeros((0, 2)) if points is None else np.asarray(points, np.float64).reshape(-1, 2)
    area = max(0.0, sum(abs(_signed(R)) * (-1 if hole else 1)
                        for R, hole, ok in zip(simple, is_hole, usable) if ok))
    boundary = sum(_resampled_count(R, h) for R, ok in zip(simple, usable) if ok)
    fixed = len(pts) + sum(len(S) for S in lines)
    est = estimate_triangles(area, boundary, fixed, max_area=max_area, min_angle=min_angle)
    if est > max_triangles:
        room = max(max_triangles - boundary - 2 * fixed, max_triangles // 2)
        raise MeshTooLarge(est, max_triangles, max_area, triangles_per_area(min_angle) * max(area, 1.0) / room)
    if not any(usable):
        return Mesh(np.zeros((0, 2)), np.zeros((0, 3), np.int64))
    use_raw = np.zeros(len(raw), bool)
    for _ in range(2):  # rings in conflict are used unsimplified; a second look confirms
        pslg, owner = _pslg([raw[i] if use_raw[i] else simple[i] for i in range(len(raw))], usable, h, lines, pts)
        bad = segment_conflicts(pslg["vertices"], pslg["segments"])
        redo = np.unique(owner[bad & (owner >= 0)])
        redo = redo[~use_raw[redo]]
        if not len(redo):
            break
        use_raw[redo] = True
    pslg = clean_pslg(pslg["vertices"], pslg["segments"])
    holes = [_hole_point(resample_ring(raw[i] if use_raw[i] else simple[i], h))
             for i in range(len(raw)) if usable[i] and is_hole[i]]
    if holes:
        pslg["holes"] = np.array(holes)
    opts = f"pq{min(float(min_angle), 34.0):g}a{float(max_area):g}YYQ"
    t = triangle.triangulate(pslg, opts)
    V = np.asarray(t["vertices"], np.float64)
    F = np.asarray(t.get("triangles", np.zeros((0, 3))), np.int64)
    return orient_and_compact(V, F)


def _pslg(rings, usable, h, lines, pts) -> tuple[dict, np.ndarray]:
    """Merged vertices and segments of the usable rings (resampled) and link polylines,
    and the ring each segment comes from (-1 for link segments)."""
    verts, segs, owner = [], [], []
    base = 0
    for i, R in enumerate(rings):
        if not usable[i]:
            continue
        R = resample_ring(R, h)
        idx = base + np.arange(len(R))
        verts.append(R)
        segs.append(np.stack([idx, np.roll(idx, -1)], axis=1))
        owner.append(np.full(len(R), i))
        base += len(R)
    for S in lines:
        idx = base + np.arange(len(S))
        verts.append(S)
        segs.append(np.stack([idx[:-1], idx[1:]], axis=1))
        owner.append(np.full(len(idx) - 1, -1))
        base += len(S)
    U, inv = merge_vertices(np.concatenate(verts + [pts]))
    return {"vertices": U, "segments": inv[np.concatenate(segs)]}, np.concatenate(owner)


def _signed(P: np.ndarray) -> float:
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def signed_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Twice the signed area of each triangle in raw (x, y) coordinates, (m,)."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]


def orient_and_compact(V: np.ndarray, F: np.ndarray) -> Mesh:
    """Drop degenerate triangles and unreferenced vertices; orient F counter-clockwise on screen."""
    if len(F):
        A = signed_areas(V, F)
        F = F[np.abs(A) > 1e-12]
        A = A[np.abs(A) > 1e-12]
        flip = A > 0  # positive raw area = clockwise as seen with y down
        F = F.copy()
        F[flip] = F[flip][:, [0, 2, 1]]
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    remap = -np.ones(len(V), np.int64)
    remap[used] = np.arange(used.sum())
    return Mesh(V[used], remap[F] if len(F) else F.reshape(0, 3))
