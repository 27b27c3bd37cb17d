"""Planar straight-line graphs for Triangle: merge what coincides, find what crosses.

Triangle, run with ``YY`` (no Steiner points on segments), cannot resolve two input
segments that cross or overlap, and may crash outright on repeated vertices; these
helpers merge the repeated vertices and find the segments in conflict.
"""
from __future__ import annotations

import numpy as np


def clean_pslg(P: np.ndarray, S: np.ndarray) -> dict:
    """Merge coincident vertices (rings that touch, a pin on a contour point) and drop
    degenerate or repeated segments.

    Parameters
    ----------
    P : (n, 2) float vertices. S : (s, 2) int segments indexing P.

    Returns
    -------
    dict with ``vertices`` (u, 2) (first occurrence's exact coordinates) and
    ``segments`` (t, 2) int32, ready for ``triangle.triangulate``.
    """
    U, inv = merge_vertices(P)
    S = inv[S]
    S = S[S[:, 0] != S[:, 1]]
    S = np.unique(np.sort(S, axis=1), axis=0)
    return {"vertices": U, "segments": S.astype(np.int32)}


def merge_vertices(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices equal to 9 decimals merged: (u, 2) unique vertices (each the first
    occurrence's exact coordinates) and (n,) index of each input vertex among them."""
    U, inv = np.unique(np.round(P, 9), axis=0, return_inverse=True)
    inv = inv.ravel()
    first = np.full(len(U), -1)
    first[inv[::-1]] = np.arange(len(P))[::-1]
    return P[first], inv


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Pairs (i, j), i < j, of segments whose bounding boxes share a grid cell, (k, 2)."""
    n = len(lo)
    if n < 2:
        return np.zeros((0, 2), np.int64)
    ext = hi - lo
    cell = max(float(np.median(ext.max(axis=1))), 1e-9)
    span = np.ptp(np.concatenate([lo, hi]), axis=0)
    while True:  # coarsen until every segment covers a modest number of cells
        c0 = np.floor(lo / cell).astype(np.int64)
        c1 = np.floor(hi / cell).astype(np.int64)
        counts = (c1[:, 0] - c0[:, 0] + 1) * (c1[:, 1] - c0[:, 1] + 1)
        if counts.sum() <= 8 * n + 64 or cell > span.max():
            break
        cell *= 2.0
    seg = np.repeat(np.arange(n), counts)
    k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    w = np.repeat(c1[:, 1] - c0[:, 1] + 1, counts)
    cx = np.repeat(c0[:, 0], counts) + k // w
    cy = np.repeat(c0[:, 1], counts) + k % w
    order = np.lexsort((seg, cy, cx))
    seg, cx, cy = seg[order], cx[order], cy[order]
    pairs = []
    d = 1
    while d < len(seg):
        same = (cx[d:] == cx[:-d]) & (cy[d:] == cy[:-d])
        if not same.any():
            break
        pairs.append(np.stack([seg[:-d][same], seg[d:][same]], axis=1))
        d += 1
    if not pairs:
        return np.zeros((0, 2), np.int64)
    return np.unique(np.sort(np.concatenate(pairs), axis=1), axis=0)


def segment_conflicts(P: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Which segments cross, touch or overlap another one other than at a shared end.

    Parameters
    ----------
    P : (n, 2) float vertices, coincident ones already merged (:func:`clean_pslg`).
    S : (s, 2) int segments.

    Returns
    -------
    (s,) bool, True for every segment in at least one conflicting pair. Near-degenerate
    contacts (within a relative 1e-9) count as conflicts.
    """
    bad = np.zeros(len(S), bool)
    keep = np.nonzero(S[:, 0] != S[:, 1])[0]  # a zero-length segment conflicts with nothing
    if len(keep) < len(S):
        bad[keep] = segment_conflicts(P, S[keep])
        return bad
    if len(S) < 2:
        return bad
    A, B = P[S[:, 0]], P[S[:, 1]]
    pairs = _candidate_pairs(np.minimum(A, B), np.maximum(A, B))
    if not len(pairs):
        return bad
    i, j = pairs[:, 0], pairs[:, 1]
    scale = max(float(np.abs(P).max()), 1.0)
    eps = 1e-9 * scale * scale

    def orient(p, q, r):
        v = (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])
        return np.where(np.abs(v) <= eps, 0.0, np.sign(v))

    a, b, c, d = A[i], B[i], A[j], B[j]
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    shared = (S[i, 0] == S[j, 0]) | (S[i, 0] == S[j, 1]) | (S[i, 1] == S[j, 0]) | (S[i, 1] == S[j, 1])
    hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
    # an endpoint exactly on the other segment: the bounding boxes must overlap too
    lo_i, hi_i = np.minimum(a, b), np.maximum(a, b)
    lo_j, hi_j = np.minimum(c, d), np.maximum(c, d)
    boxes = np.all((lo_i <= hi_j) & (lo_j <= hi_i), axis=1)
    conflict = hit & boxes & ~shared
    # sharing one end: a conflict only when collinear and pointing the same way (overlap)
    if shared.any():
        si = np.nonzero(shared)[0]
        pa, pb, pc, pd = a[si], b[si], c[si], d[si]
        ia, ib, ic, idd = S[i[si], 0], S[i[si], 1], S[j[si], 0], S[j[si], 1]
        hub = np.where((ia == ic) | (ia == idd), 0, 1)
        h = np.where(hub[:, None] == 0, pa, pb)
        u = np.where(hub[:, None] == 0, pb, pa) - h
        far_j = np.where(((ic == ia) | (ic == ib))[:, None], pd, pc)
        v = far_j - h
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        dot = (u * v).sum(axis=1)
        same_pair = ((ia == ic) & (ib == idd)) | ((ia == idd) & (ib == ic))
        conflict[si] = (np.abs(cross) <= eps) & (dot > 0) & ~same_pair
    bad[i[conflict]] = True
    bad[j[conflict]] = True
    return bad
