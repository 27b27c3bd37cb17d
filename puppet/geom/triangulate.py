"""Constrained quality Delaunay triangulation of mask regions (Shewchuk's Triangle).

Pins become vertices; link segments become constrained edges. Segments are never split
by Triangle (switch ``YY``): we subdivide them ourselves first, so two linked layers get
exactly the same vertices along a shared link segment.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.geom.contour import Region, resample_ring, simplify_ring


@dataclass
class Mesh:
    """A triangle mesh in canvas coordinates.

    V : (n, 2) float vertices. F : (m, 3) int triangles, counter-clockwise as seen on
    screen (y down), i.e. negative signed area in raw (x, y) coordinates.
    """

    V: np.ndarray
    F: np.ndarray


def edge_length_for_area(max_area: float) -> float:
    """Edge length of an equilateral triangle of area ``max_area``."""
    return float(np.sqrt(4.0 * max_area / np.sqrt(3.0)))


def _hole_point(ring: np.ndarray) -> np.ndarray:
    """A point strictly inside a simple closed ring (centroid of its largest triangle)."""
    import triangle

    n = len(ring)
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    t = triangle.triangulate({"vertices": ring, "segments": seg}, "pQ")
    T = t["triangles"]
    W = t["vertices"]
    a, b, c = W[T[:, 0]], W[T[:, 1]], W[T[:, 2]]
    area = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    k = int(np.argmax(area))
    return (a[k] + b[k] + c[k]) / 3.0


def triangulate_regions(
    regions: list[Region],
    *,
    max_area: float,
    min_angle: float = 25.0,
    simplify: float = 1.0,
    points: np.ndarray | None = None,
    segments: list[np.ndarray] | None = None,
) -> Mesh:
    """Quality constrained Delaunay triangulation of the regions.

    Parameters
    ----------
    regions : outer rings and holes (canvas coordinates), from ``mask_regions``.
    max_area : largest triangle area, px^2.
    min_angle : smallest angle Triangle aims for, degrees (at most 34).
    simplify : Douglas-Peucker tolerance for the rings, px.
    points : (p, 2) points that must be vertices (pins).
    segments : polylines (each (s, 2), already subdivided) that must be edges (links).

    Returns
    -------
    Mesh with vertices of unreferenced points removed.
    """
    import triangle

    h = edge_length_for_area(max_area)
    verts, segs, holes = [], [], []
    base = 0

    def add_ring(R):
        nonlocal base
        n = len(R)
        verts.append(R)
        idx = base + np.arange(n)
        segs.append(np.stack([idx, np.roll(idx, -1)], axis=1))
        base += n

    for reg in regions:
        ring = resample_ring(simplify_ring(reg.outer, simplify), h)
        if len(ring) < 3 or abs(_signed(ring)) < 1e-6:
            continue
        add_ring(ring)
        for hole in reg.holes:
            hr = resample_ring(simplify_ring(hole, simplify), h)
            if len(hr) < 3 or abs(_signed(hr)) < 1e-6:
                continue
            add_ring(hr)
            holes.append(_hole_point(hr))
    if not verts:
        return Mesh(np.zeros((0, 2)), np.zeros((0, 3), np.int64))
    for S in segments or []:
        n = len(S)
        verts.append(np.asarray(S, np.float64))
        idx = base + np.arange(n)
        segs.append(np.stack([idx[:-1], idx[1:]], axis=1))
        base += n
    if points is not None and len(points):
        verts.append(np.asarray(points, np.float64).reshape(-1, 2))
    pslg = clean_pslg(np.concatenate(verts), np.concatenate(segs))
    if holes:
        pslg["holes"] = np.array(holes)
    opts = f"pq{min(float(min_angle), 34.0):g}a{float(max_area):g}YYQ"
    t = triangle.triangulate(pslg, opts)
    V = np.asarray(t["vertices"], np.float64)
    F = np.asarray(t.get("triangles", np.zeros((0, 3))), np.int64)
    return orient_and_compact(V, F)


def clean_pslg(P: np.ndarray, S: np.ndarray) -> dict:
    """Merge coincident vertices (rings that touch, a pin on a contour point) and drop
    degenerate or repeated segments: Triangle may crash on either."""
    key = np.round(P, 9)
    U, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    # keep the first occurrence's exact coordinates
    first = np.full(len(U), -1)
    first[inv[::-1]] = np.arange(len(P))[::-1]
    S = inv[S]
    S = S[S[:, 0] != S[:, 1]]
    S = np.unique(np.sort(S, axis=1), axis=0)
    return {"vertices": P[first], "segments": S.astype(np.int32)}


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
