"""As-rigid-as-possible in-betweens of two deformed meshes (Alexa, Cohen-Or and Levin,
"As-Rigid-As-Possible Shape Interpolation", SIGGRAPH 2000), on a common rest mesh.

Each triangle's deformation gradient J (rest -> key) is split by a polar decomposition
into a rotation by angle theta and a symmetric stretch S. Between key A and key B at
fraction u the wanted gradient is ``R((1-u) theta_A + u theta_B) ((1-u) S_A + u S_B)``:
rotation and stretch are interpolated separately, so a limb swinging 180 degrees turns
instead of shrinking through its joint as straight-line vertex paths do. Each triangle
turns the short way unless that is nearly half a turn; then it turns the way its
neighbours do (a spanning tree of the triangle adjacency along the smallest jumps), so a
limb turned 180 degrees turns all one way round. Both depend only on the two key meshes
(trajectory invariance: no frame depends on the frame before it).

The vertices are then the least-squares fit of those gradients (a Poisson solve with the
cotangent Laplacian, factorised once per mesh and fixed set): vertices in ``fixed``
(pins that do not move between the keys) stay exactly where they are; a connected part
with no fixed vertex is placed by a weighted fit of ``anchors`` (its pins) to their
straight-line positions, the least-moving anchors weighing most. At u = 0 and u = 1 the
solve reproduces the key meshes (to solver precision).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from puppet.deform.factor import factorize
from puppet.geom.geodesic import connected_components
from puppet.geom.laplacian import laplacian_from_weights, spring_weights
from puppet.geom.mesh import check_mesh

_CORNERS = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])  # d(edge vectors)/d(corner positions)


def _edge_matrices(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(m, 2, 2): columns are the edges v1 - v0 and v2 - v0 of each triangle."""
    return np.stack([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]], axis=-1)


def jacobians(V: np.ndarray, F: np.ndarray, U: np.ndarray) -> np.ndarray:
    """Deformation gradient of each triangle from rest ``V`` (n, 2) to ``U`` (n, 2): (m, 2, 2)."""
    return _edge_matrices(U, F) @ np.linalg.inv(_edge_matrices(V, F))


def polar2(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest rotations and stretches of 2x2 matrices: ``J = R(theta) S``.

    Parameters
    ----------
    J : (m, 2, 2)

    Returns
    -------
    theta : (m,) angles in (-pi, pi], ``R(theta) = [[cos, -sin], [sin, cos]]``, the
        rotation nearest J in the Frobenius norm.
    S : (m, 2, 2) symmetric, ``R(theta)^T J`` (positive definite when det J > 0).
    """
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    theta = np.arctan2(c - b, a + d)
    return theta, np.swapaxes(rotations(theta), 1, 2) @ J


def rotations(theta: np.ndarray) -> np.ndarray:
    """(m, 2, 2) rotation matrices of angles ``theta`` (m,)."""
    co, si = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([co, -si], -1), np.stack([si, co], -1)], -2)


def _wrap(x: np.ndarray) -> np.ndarray:
    """Angles into [-pi, pi)."""
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def triangle_adjacency(F: np.ndarray) -> np.ndarray:
    """Pairs of triangles sharing an edge: (e, 2) indices into F."""
    m = len(F)
    E = np.sort(F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    key = E[:, 0].astype(np.int64) * (int(F.max(initial=0)) + 1) + E[:, 1]
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    tri = np.repeat(np.arange(m), 3)[order]
    return np.stack([tri[:-1][same], tri[1:][same]], axis=1)


#: A triangle turning more than this (radians) between two keys is "nearly half a turn":
#: which way round it went is taken from its neighbours, not from the short way.
HALF_TURN = np.radians(150.0)


def unwrap_angles(F: np.ndarray, delta: np.ndarray, *, half_turn: float = HALF_TURN) -> np.ndarray:
    """Per-triangle rotation angles between two keys, ``delta`` (m,) modulo 2 pi, made
    into the turns the in-between takes.

    Each triangle turns the short way (|angle| <= pi) unless that is nearly half a turn
    (more than ``half_turn``): such a triangle takes the value nearest its parent's in a
    minimum spanning tree of the triangle adjacency, weighted by the wrapped jump between
    neighbours and grown in each connected part from the triangle that turns least. So a
    limb turned 180 degrees turns the same way round all along (the way the joint's
    triangles show), while a part that turned less than ``half_turn`` turns the short
    way even where a twisted joint would wind it round the long way. Deterministic:
    depends only on ``F`` and ``delta``.
    """
    # (SciPy's components of a graph; the module's connected_components is a mesh's)
    from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
    from scipy.sparse.csgraph import connected_components as graph_components

    m = len(F)
    d = _wrap(delta)
    if m == 0:
        return d
    P = triangle_adjacency(F)
    w = np.abs(_wrap(d[P[:, 0]] - d[P[:, 1]])) + 1e-9  # explicit zeros would drop the edge
    A = sp.coo_matrix((w, (P[:, 0], P[:, 1])), shape=(m, m)).tocsr()
    T = minimum_spanning_tree(A)
    T = T + T.T
    ncomp, label = graph_components(T, directed=False)
    parent = np.arange(m)
    for c in range(ncomp):
        members = np.flatnonzero(label == c)
        root = int(members[np.argmin(np.abs(d[members]))])
        order, pred = breadth_first_order(T, root, directed=False, return_predecessors=True)
        parent[order[1:]] = pred[order[1:]]
    short = np.flatnonzero(np.abs(d) <= half_turn)
    parent[short] = short  # the short way: each its own root
    # k_j = k_parent - round((d_j - d_parent) / 2 pi), summed down from each root by pointer jumping
    k = -np.rint((d - d[parent]) / (2 * np.pi)).astype(np.int64)
    p = parent.copy()
    while np.any(p != p[p]):
        k = k + k[p]
        p = p[p]
    return d + 2 * np.pi * k


@dataclass
class InterpData:
    """What :func:`interp_solve` needs for one rest mesh and one set of fixed vertices."""

    V: np.ndarray  # (n, 2) rest vertices
    F: np.ndarray  # (m, 3)
    G: sp.csr_matrix  # (2m, n): row 2f+c = column c of triangle f's gradient of one coordinate
    GTW: sp.csr_matrix  # (n, 2m) G^T times triangle areas
    fixed: np.ndarray  # (f,) vertices held where both keys put them
    held: np.ndarray  # fixed + one vertex of each part with no fixed vertex
    free: np.ndarray  # the other vertices
    K_fh: sp.csr_matrix  # (free, held) block of the Laplacian
    factor: object  # of the (free, free) block
    parts: list[np.ndarray]  # vertices of each connected part with no fixed vertex


def interp_precompute(V, F, fixed=(), *, solver: str = "qdldl", couple=None) -> InterpData:
    """Gradient operator and the factorised Poisson system of a rest mesh.

    Parameters
    ----------
    V : (n, 2) float rest vertices; F : (m, 3) int triangles.
    fixed : (f,) int vertices that stay put between the two keys.
    couple : ((p, 2) int, (p,) float), optional
        Springs ``kappa |u_a - u_b|^2`` between vertices at one rest point (links of
        strength below 1, as in ARAP): added to the Poisson system, so the parts they tie
        stay tied between the keys and count as one component.
    """
    V, F = check_mesh(V, F)
    n, m = len(V), len(F)
    E = _edge_matrices(V, F)
    det = E[:, 0, 0] * E[:, 1, 1] - E[:, 0, 1] * E[:, 1, 0]
    ok = np.abs(det) > 1e-12 * max(float(np.abs(det).max(initial=0.0)), 1e-300)
    Einv = np.zeros_like(E)
    Einv[ok] = np.linalg.inv(E[ok])
    Dm = np.einsum("kj,mjc->mkc", _CORNERS, Einv)  # (m, 3, 2)
    rows = (2 * np.arange(m)[:, None, None] + np.arange(2)[None, None, :]).repeat(3, axis=1)
    cols = np.broadcast_to(F[:, :, None], (m, 3, 2))
    G = sp.csr_matrix((Dm.ravel(), (rows.ravel(), cols.ravel())), shape=(2 * m, n))
    area = np.where(ok, 0.5 * np.abs(det), 0.0)
    GTW = (G.T @ sp.diags(np.repeat(area, 2))).tocsr()
    K = (GTW @ G).tocsr()
    fixed = np.unique(np.asarray(fixed, dtype=np.int64).reshape(-1))
    if couple is not None and len(couple[0]):
        K, label = _with_springs(K, F, *couple)
        ncomp = int(label.max()) + 1
    else:
        ncomp, label = connected_components(n, F)
    has_fixed = np.zeros(ncomp, bool)
    has_fixed[label[fixed]] = True
    parts = [np.flatnonzero(label == c) for c in range(ncomp) if not has_fixed[c]]
    held = np.unique(np.concatenate([fixed] + [p[:1] for p in parts]).astype(np.int64))
    free = np.setdiff1d(np.arange(n), held)
    Kf = K[free][:, free]
    return InterpData(V=V, F=F, G=G, GTW=GTW, fixed=fixed, held=held, free=free,
                      K_fh=K[free][:, held].tocsr(), factor=factorize(Kf, solver) if len(free) else None,
                      parts=parts)


def _with_springs(K, F, pairs, kappa):
    """K plus the springs' Laplacian, and the components of the mesh joined by them."""
    # lazy: csgraph loads scipy.linalg, 0.1 s of each start
    from scipy.sparse.csgraph import connected_components as graph_components

    n = K.shape[0]
    S = spring_weights(n, pairs, kappa)
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]], np.asarray(pairs, np.int64).reshape(-1, 2)])
    graph = sp.csr_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return (K + laplacian_from_weights(S)).tocsr(), graph_components(graph, directed=False)[1]


@dataclass
class KeyPair:
    """Two key meshes split into per-triangle rotations and stretches."""

    UA: np.ndarray  # (n, 2)
    UB: np.ndarray  # (n, 2)
    theta_a: np.ndarray  # (m,)
    delta: np.ndarray  # (m,) unwrapped theta_B - theta_A
    SA: np.ndarray  # (m, 2, 2)
    SB: np.ndarray  # (m, 2, 2)


def interp_pair(data: InterpData, UA, UB) -> KeyPair:
    """Rotations and stretches of key meshes ``UA``, ``UB`` (n, 2) over ``data``'s rest mesh."""
    UA, UB = np.asarray(UA, float), np.asarray(UB, float)
    ta, SA = polar2(jacobians(data.V, data.F, UA))
    tb, SB = polar2(jacobians(data.V, data.F, UB))
    return KeyPair(UA=UA, UB=UB, theta_a=ta, delta=unwrap_angles(data.F, tb - ta), SA=SA, SB=SB)


def interp_gradients(pair: KeyPair, u: float) -> np.ndarray:
    """The wanted gradients at fraction ``u``: R(theta_A + u delta) ((1-u) S_A + u S_B), (m, 2, 2)."""
    th = pair.theta_a + u * pair.delta
    co, si = np.cos(th), np.sin(th)
    S = (1.0 - u) * pair.SA + u * pair.SB
    s00, s01, s10, s11 = S[:, 0, 0], S[:, 0, 1], S[:, 1, 0], S[:, 1, 1]
    J = np.empty_like(S)
    J[:, 0, 0] = co * s00 - si * s10
    J[:, 0, 1] = co * s01 - si * s11
    J[:, 1, 0] = si * s00 + co * s10
    J[:, 1, 1] = si * s01 + co * s11
    return J


def interp_solve(data: InterpData, pair: KeyPair, u: float, *, anchors=None) -> np.ndarray:
    """The in-between mesh at fraction ``u`` (0 = key A, 1 = key B): (n, 2).

    ``anchors`` (a,) int: vertices (pins) whose straight-line positions place each part
    that has no fixed vertex, weighted by 1 / (1 + |B - A|)^2 (pixels); a part without
    anchors is placed by the straight-line path of its vertex centroid.
    """
    J = interp_gradients(pair, float(u))
    n = len(data.V)
    U = np.empty((n, 2))
    U[data.held] = pair.UA[data.held]
    if len(data.free):
        rhs = data.GTW @ J.transpose(0, 2, 1).reshape(-1, 2)
        # row 2f+c of G applied to one coordinate r gives J[f, r, c]
        B = rhs[data.free] - data.K_fh @ U[data.held]
        U[data.free] = data.factor.solve(np.ascontiguousarray(B))
    anchors = np.zeros(0, np.int64) if anchors is None else np.asarray(anchors, np.int64)
    line = (1.0 - u) * pair.UA + u * pair.UB
    for part in data.parts:
        a = np.intersect1d(anchors, part)
        if len(a) == 0:
            a = part
        w = 1.0 / (1.0 + np.linalg.norm(pair.UB[a] - pair.UA[a], axis=1)) ** 2
        U[part] += (w[:, None] * (line[a] - U[a])).sum(axis=0) / w.sum()
    return U
