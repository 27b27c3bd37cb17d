"""Exterior control points: boundary edits on top of the coarse (ARAP) deformation.

Garment-retargeting paper, section 3.3. Exterior points lie on or near the contour.

(a) **Riding along** (eqs. 8-11). Each exterior point ``e`` is stored in the local frame
of a mesh edge ``v1 -> v2``::

    e = v1 + s (v2 - v1) + t R90 (v2 - v1),      R90 (x, y) = (-y, x)

(``s`` along the edge, ``t`` across it, both in units of the edge length), and after a
coarse deformation ``U`` it is at ``U[v1] + s (U[v2] - U[v1]) + t R90 (U[v2] - U[v1])``.
Rotations, translations and uniform scales of ``U`` move it exactly like the mesh.
The edge is the nearest *boundary* edge of the mesh (given ``F``): the frame then
follows the contour's own tangent, ``s`` is in ``[0, 1]`` (but beyond a convex
corner) and ``t`` is the signed distance to the contour over the edge length, which
is well conditioned. Without ``F``, the paper's two nearest vertices are used (the
second is the nearest one at a different position).

(b) **Fine mode.** The coarsely deformed mesh is taken as the new rest, and an
object-space MLS warp driven by the exterior points moves the vertices of a band
along the boundary (:func:`fine_deform`):

* controls: the exterior points (``mode="points"``), or the straight segments between
  consecutive exterior points along the contour (``mode="lines"``), sampled densely
  (every ``line_spacing``) with targets interpolated along the target segments;
* anchors, which stay exactly where they are: the interior pins ``b_anchor`` and every
  vertex farther than ``falloff`` from the boundary (distance along mesh edges). Only
  the anchors adjacent to the band are used as MLS controls (the ones behind them are
  shadowed), so the cost is that of the band, not of the mesh;
* weights ``w = D^(-2 alpha)`` over the interior (geodesic) distance ``D`` along mesh
  edges, from the control's nearest vertex plus the straight distance to it, so a drag
  on one leg does not pull the neighbouring leg across the gap (``distance="euclidean"``
  gives image-space MLS). Exterior points and pins are point controls (factor 1);
  the samples of a control line and of the anchor front stand for pieces of a curve
  and are weighted by their length element over ``pi * falloff``, so the result does
  not depend on the mesh resolution or the sampling, and (for ``alpha = 1``) a whole
  straight line at distance ``d`` weighs like a point at distance ``sqrt(d falloff)``:
  an exterior point and the anchor front balance about ``falloff`` away from it;
* compact support: the exterior controls' weights are tapered to 0 at ``radius``
  (default ``3 * falloff``), so beyond it only the (fixed) anchors act and the mesh
  is exactly still; within ``radius / 2`` the weights are the plain ones;
* a smooth join: the MLS displacement of a free vertex is scaled by
  ``smoothstep(d / falloff)``, ``d`` its distance (along edges) to the anchor front,
  so the band meets the still interior without a crease; the boundary, at least
  ``falloff`` from the front, is not scaled, and a thin part with no front near it
  moves as a whole (pins are point controls: MLS alone makes the mesh around them
  continuous);
* a vertex at an exterior point lands exactly on its target; with all targets at rest
  the mesh is returned unchanged.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from puppet.deform.mls import KINDS, inverse_distance_weights, mls_from_weights
from puppet.deform.threads import blas_capped
from puppet.geom.geodesic import edge_graph
from puppet.geom.mesh import boundary_edges, check_faces, check_vertices, edges

__all__ = [
    "ExteriorFrame",
    "boundary_edges",
    "exterior_frame",
    "exterior_positions",
    "default_falloff",
    "fine_deform",
]


class ExteriorFrame(NamedTuple):
    """Exterior points relative to mesh edges: ``e = v1 + s d + t R90(d)``, ``d = v2 - v1``.

    v1, v2 : (j,) int vertex indices; s, t : (j,) float.
    """

    v1: np.ndarray
    v2: np.ndarray
    s: np.ndarray
    t: np.ndarray


def _points(X, name) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1 and X.size == 0:
        X = X.reshape(0, 2)
    if X.ndim != 2 or X.shape[1] != 2:
        raise ValueError(f"{name} must have shape (k, 2), got {X.shape}")
    return X


def _frame_from_edges(V, e, a, b) -> ExteriorFrame:
    d = V[b] - V[a]
    r = e - V[a]
    dd = np.einsum("ij,ij->i", d, d)
    s = np.einsum("ij,ij->i", r, d) / dd
    t = (r[:, 1] * d[:, 0] - r[:, 0] * d[:, 1]) / dd  # r . R90(d), R90(d) = (-dy, dx)
    return ExteriorFrame(a.astype(np.int64), b.astype(np.int64), s, t)


def _nearest_two_vertices(V, e):
    k = min(len(V), 8)
    from scipy.spatial import cKDTree  # lazily: scipy.spatial costs ~140 ms to import

    _, idx = cKDTree(V).query(e, k=k)
    idx = idx.reshape(len(e), k)
    differs = np.any(V[idx] != V[idx[:, :1]], axis=2)
    differs[:, 0] = False
    if not differs.any(axis=1).all():
        raise ValueError("no two distinct mesh vertices near an exterior point")
    return idx[:, 0], idx[np.arange(len(e)), differs.argmax(axis=1)]


def _nearest_edges(V, e, E):
    A, B = V[E[:, 0]], V[E[:, 1]]
    d = B - A
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    r = e[:, None, :] - A[None]  # (j, b, 2)
    u = np.clip(np.einsum("jbk,bk->jb", r, d) / dd, 0.0, 1.0)
    gap = r - u[..., None] * d[None]
    return np.einsum("jbk,jbk->jb", gap, gap).argmin(axis=1)


def exterior_frame(V, e, F=None) -> ExteriorFrame:
    """Local edge frames of exterior points (eqs. 8-11).

    Parameters
    ----------
    V : (n, 2) float
        Rest vertices.
    e : (j, 2) float
        Exterior points (on or near the contour).
    F : (m, 3) int, optional
        Triangles. When given, each point is framed on its nearest boundary edge
        (closest point on the segment; ties -> the first edge of
        :func:`boundary_edges`); otherwise on its two nearest vertices.

    Returns
    -------
    ExteriorFrame (v1, v2, s, t), with ``e == V[v1] + s (V[v2] - V[v1]) + t R90(V[v2] - V[v1])``.
    """
    V = _points(V, "V")
    e = _points(e, "e")
    if len(e) == 0:
        z = np.zeros(0)
        return ExteriorFrame(np.zeros(0, np.int64), np.zeros(0, np.int64), z, z.copy())
    E = boundary_edges(F) if F is not None else np.zeros((0, 2), np.int64)
    if len(E):
        k = _nearest_edges(V, e, E)
        a, b = E[k, 0], E[k, 1]
    else:
        if len(V) < 2:
            raise ValueError("an exterior frame needs at least two vertices")
        a, b = _nearest_two_vertices(V, e)
    return _frame_from_edges(V, e, a, b)


def exterior_positions(U, frame: ExteriorFrame) -> np.ndarray:
    """Where framed exterior points are on a deformed mesh.

    Parameters
    ----------
    U : (n, 2) float
        Deformed vertices (same indexing as the frame's rest mesh).
    frame : ExteriorFrame
        From :func:`exterior_frame`.

    Returns
    -------
    E : (j, 2) float
        ``(1 - s) U[v1] + s U[v2] + t R90(U[v2] - U[v1])``; a point at a vertex
        (``s`` in {0, 1}, ``t == 0``) is exactly that vertex's position.
    """
    U = _points(U, "U")
    v1, v2, s, t = frame
    a, b = U[v1], U[v2]
    d = b - a
    return (1.0 - s)[:, None] * a + s[:, None] * b + t[:, None] * np.stack([-d[:, 1], d[:, 0]], axis=1)


def _boundary_edge_length(V, E) -> float:
    if len(E) == 0:
        return 0.0
    return float(np.median(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)))


def default_falloff(V, F, ext_rest) -> float:
    """Depth of the band that fine mode deforms (see :func:`fine_deform`).

    Half the median distance from each exterior point to its nearest other one (so an
    exterior point's influence reaches about halfway to its neighbours, along the
    contour and inward alike); with a single point, a quarter of the square root of
    the mesh area. Never less than two boundary edge lengths.
    """
    V = _points(V, "V")
    p = _points(ext_rest, "ext_rest")
    E = boundary_edges(F)
    h = _boundary_edge_length(V, E)
    if len(p) >= 2:
        from scipy.spatial import cKDTree

        dist, _ = cKDTree(p).query(p, k=2)
        f = 0.5 * float(np.median(dist[:, 1]))
    else:
        F = np.asarray(F, np.int64).reshape(-1, 3)
        a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]).sum()
        f = 0.25 * float(np.sqrt(area))
    return max(f, 2.0 * h)


def _line_controls(p, q, segments, spacing):
    """Exterior points plus samples inside each segment (targets interpolated).

    Returns rest and target positions and each sample's length element (0 for the
    exterior points themselves, which are point controls).
    """
    S = np.asarray(segments, np.int64).reshape(-1, 2)
    A, B = p[S[:, 0]], p[S[:, 1]]
    length = np.linalg.norm(B - A, axis=1)
    m = np.maximum(1, np.ceil(length / spacing).astype(np.int64))
    seg = np.repeat(np.arange(len(S)), m - 1)
    k = np.arange(seg.size) - np.repeat(np.cumsum(m - 1) - (m - 1), m - 1) + 1
    t = (k / m[seg])[:, None]
    cp = np.concatenate([p, (1 - t) * A[seg] + t * B[seg]])
    cq = np.concatenate([q, (1 - t) * q[S[seg, 0]] + t * q[S[seg, 1]]])
    ds = np.concatenate([np.zeros(len(p)), (length / m)[seg]])
    return cp, cq, ds


def _consecutive(j: int) -> np.ndarray:
    if j < 2:
        return np.zeros((0, 2), np.int64)
    if j == 2:
        return np.array([[0, 1]])
    return np.stack([np.arange(j), (np.arange(j) + 1) % j], axis=1)


@blas_capped
def fine_deform(
    V_rest,
    F,
    b_anchor,
    ext_rest,
    ext_target,
    *,
    mode: str = "points",
    falloff: float | None = None,
    distance: str = "geodesic",
    kind: str = "rigid",
    alpha: float = 1.0,
    segments=None,
    line_spacing: float | None = None,
    radius: float | None = None,
) -> np.ndarray:
    """Fine-mode boundary warp: exterior points drag the boundary band of a mesh.

    Parameters
    ----------
    V_rest : (n, 2) float
        The rest of this step: normally the coarsely (ARAP) deformed mesh ``U``.
    F : (m, 3) int
        Triangles.
    b_anchor : (a,) int
        Vertices that must not move (the interior pins).
    ext_rest : (j, 2) float
        Exterior points on ``V_rest`` (e.g. :func:`exterior_positions` of ``U``), in
        contour order for ``mode="lines"``.
    ext_target : (j, 2) float
        Where they should go.
    mode : {"points", "lines"}
        Exterior points as MLS control points, or the segments between consecutive
        exterior points as control lines (sampled every ``line_spacing``).
    falloff : float, optional
        Vertices farther than this from the boundary (along mesh edges) are anchors and
        do not move. Default :func:`default_falloff`.
    distance : {"geodesic", "euclidean"}
        Control-to-vertex distance of the MLS weights: along mesh edges (object space,
        from the control's nearest vertex plus the straight distance to it) or straight.
    kind : {"rigid", "similarity", "affine"}
        MLS family.
    alpha : float
        MLS weight exponent, ``w = D^(-2 alpha)``.
    segments : (s, 2) int, optional
        ``mode="lines"`` only: pairs of exterior indices; default consecutive points
        of a closed contour ``(0, 1), (1, 2), ..., (j-1, 0)``.
    line_spacing : float, optional
        Sampling step of control lines; default the median boundary edge length.
    radius : float, optional
        Reach of the exterior controls (same distance as the weights): their weights
        are multiplied by a taper that is 1 up to ``radius / 2`` and falls smoothly
        (C1) to 0 at ``radius``, so an edit never moves anything farther than
        ``radius`` from the exterior controls. Default ``3 * falloff``; ``inf`` turns
        the taper off. Not applied to a connected part with no anchor.

    Returns
    -------
    U : (n, 2) float
        Deformed vertices. Anchors and vertices deeper than ``falloff`` are exactly at
        ``V_rest``, and the displacement fades in smoothly from them; a free vertex
        exactly at an exterior rest point is exactly at its target;
        ``ext_target == ext_rest`` returns ``V_rest`` unchanged. Large inward drags
        can fold triangles near the dragged point (relax them afterwards).
    """
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    V, F, p, q = _check_fine(V_rest, F, ext_rest, ext_target, mode, distance, kind)
    U = V.copy()
    if len(p) == 0 or np.array_equal(p, q) or len(F) == 0:
        return U
    falloff = default_falloff(V, F, p) if falloff is None else float(falloff)
    radius = 3.0 * falloff if radius is None else float(radius)
    G = edge_graph(V, F)
    free, pins, front = _band(V, F, G, b_anchor, falloff)
    if not free.any():
        return U
    anchors = np.r_[pins, front]
    cp, cq, mult = _controls(V, F, p, q, pins, front, falloff, mode, segments, line_spacing)
    D = _control_distances(V, G, cp, anchors, free, distance)
    # fade in from the anchor front over falloff: the band joins the still part smoothly
    # (a pin is a point control: MLS alone keeps its surroundings continuous)
    fade = np.ones(int(free.sum()))
    if len(front):
        fade = _smoothstep(csgraph.dijkstra(G, indices=front, min_only=True)[free] / falloff)
    U[free] = _tapered_mls(V[free], D, cp, cq, mult, len(cp) - len(anchors), radius, kind, alpha, fade)
    return U


def _check_fine(V_rest, F, ext_rest, ext_target, mode, distance, kind):
    if mode not in ("points", "lines"):
        raise ValueError(f"mode must be 'points' or 'lines', got {mode!r}")
    if distance not in ("geodesic", "euclidean"):
        raise ValueError(f"distance must be 'geodesic' or 'euclidean', got {distance!r}")
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    p = _points(ext_rest, "ext_rest")
    q = _points(ext_target, "ext_target")
    if p.shape != q.shape:
        raise ValueError(f"ext_rest and ext_target differ in shape: {p.shape}, {q.shape}")
    V = check_vertices(V_rest, name="V_rest")
    return V, check_faces(F, len(V)), p, q


def _controls(V, F, p, q, pins, front, falloff, mode, segments, line_spacing):
    """Rest and target positions of all MLS controls (anchors last) and their weight
    factors: 1 for points (exterior points, pins); for the samples of a control line
    or of the anchor front, their length element over ``pi * falloff``."""
    if mode == "lines":
        spacing = line_spacing or _boundary_edge_length(V, boundary_edges(F)) or 1.0
        cp, cq, ds = _line_controls(p, q, _consecutive(len(p)) if segments is None else segments, spacing)
    else:
        cp, cq, ds = p, q, np.zeros(len(p))
    h = float(np.median(np.linalg.norm(np.diff(V[edges(F)], axis=1)[:, 0], axis=1)))
    scale = np.pi * falloff
    mult = np.r_[np.where(ds > 0, ds / scale, 1.0), np.ones(len(pins)), np.full(len(front), h / scale)]
    anchors = np.r_[pins, front]
    return np.concatenate([cp, V[anchors]]), np.concatenate([cq, V[anchors]]), mult


def _band(V, F, G, b_anchor, falloff):
    """Free vertices (within ``falloff`` of the boundary, not pins), the pins, and the
    deep vertices that share an edge with the band (the anchor front)."""
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    depth = csgraph.dijkstra(G, indices=np.unique(boundary_edges(F)), min_only=True)
    held = np.zeros(len(V), bool)
    held[np.asarray(b_anchor, np.int64).reshape(-1)] = True
    free = (depth <= falloff) & ~held
    Gc = G.tocoo()
    front = np.zeros(len(V), bool)
    front[Gc.col[free[Gc.row]]] = True
    return free, np.flatnonzero(held), np.flatnonzero(front & ~free & ~held)


def _control_distances(V, G, cp, anchors, free, distance):
    """(k, n_free) distances from the controls (anchors last) to the free vertices."""
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    if distance == "euclidean":
        return np.hypot(cp[:, 0, None] - V[None, free, 0], cp[:, 1, None] - V[None, free, 1])
    kc = len(cp) - len(anchors)
    from scipy.spatial import cKDTree

    gap, near = cKDTree(V).query(cp)
    near[kc:] = anchors  # anchors are vertices: exact sources
    gap[kc:] = 0.0
    src, inv = np.unique(near, return_inverse=True)
    return csgraph.dijkstra(G, indices=src)[:, free][inv] + gap[:, None]


def _smoothstep(x: np.ndarray) -> np.ndarray:
    """0 up to 0, C1 cubic rise to 1 at 1, 1 beyond."""
    s = np.clip(x, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _taper(x: np.ndarray) -> np.ndarray:
    """1 up to 1/2, C1 smoothstep down to 0 at 1, 0 beyond."""
    return 1.0 - _smoothstep(2.0 * x - 1.0)


def _tapered_mls(X, D, cp, cq, mult, kc, radius, kind, alpha, fade):
    """MLS with weights ``mult * D^(-2 alpha)``, compactly supported on the first ``kc``.

    The taper applies only where some anchor (controls ``kc:``) is reachable, so every
    tapered column keeps a positive weight sum and the field stays continuous.
    """
    W, exact, reachable = inverse_distance_weights(D, alpha=alpha)
    W *= mult[:, None]
    anchored = np.isfinite(D[kc:]).any(axis=0) if len(D) > kc else np.zeros(D.shape[1], bool)
    if np.isfinite(radius):
        W[:kc, anchored] *= _taper(D[:kc, anchored] / radius)
    U = X.copy()
    todo = reachable & (exact < 0) & (W.sum(axis=0) > 0)
    if todo.any():
        M = mls_from_weights(X[todo], cp, cq, W[:, todo], kind=kind)
        U[todo] = X[todo] + fade[todo, None] * (M - X[todo])
    hit = exact >= 0
    U[hit] = cq[exact[hit]]
    return U
