"""Cage coordinates: mean value, harmonic and Green coordinates of points with respect to
a closed polygon (the cage), a precomputed cage map, landmark fitting and cage checks.

A point set ``X`` is written once in coordinates of the rest cage ``C`` (m vertices); a
posed cage ``C'`` then carries it by one matrix product. Every kind is linear in ``C'``:

* ``mvc`` (Floater 2003; Hormann & Floater 2006): ``X' = W C'``, rows of ``W`` sum to 1,
  exact for affine maps of the cage, defined in the whole plane.
* ``harmonic`` (Joshi et al. 2007): the same form, ``W`` the discrete harmonic functions
  of a triangle mesh of the cage's interior (piecewise linear along the cage), looked up
  at ``X``; non-negative, exact for affine maps, ``X`` inside the cage.
* ``green`` (Lipman, Levin & Cohen-Or 2008), in its conformal 2D form:
  ``X' = sum_j phi_j v'_j + sum_k psi_k s_k n'_k`` with ``n'_k`` the outward unit normal
  of the posed edge ``k`` and ``s_k = |e'_k| / |e_k|``. Since ``s_k n'_k`` is the posed
  edge turned by a quarter turn over ``|e_k|``, the map is ``X' = Phi C' + B C' J``
  (``J`` the quarter turn), in complex numbers ``z' = sum_j (Phi - i B)_j w'_j``: a
  Cauchy-type complex barycentric map (Weber, Ben-Chen & Gotsman 2009), holomorphic in
  ``z``, hence conformal; exact for similarities. ``X`` inside the cage (or on it).

All arrays are canvas coordinates (x right, y down); either cage orientation works.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from puppet.geom.contour import ring_area
from puppet.geom.laplacian import cotangent_laplacian

__all__ = ["KINDS", "MAX_COORD", "CageMap", "mvc", "green", "harmonic", "harmonic_mesh",
           "harmonic_weights", "HarmonicMesh", "CageFit", "fit_cage", "check_cage", "check_encloses", "auto_cage", "winding"]

#: The coordinate kinds, the default first.
KINDS = ("green", "mvc", "harmonic")
#: Largest absolute cage coordinate accepted (px), as the scene format's coordinates.
MAX_COORD = 1e6
_QUARTER = np.array([[0.0, -1.0], [1.0, 0.0]])  # row vector e @ _QUARTER = (e_y, -e_x)
_CHUNK = 8192  # points per block of the (n, m) temporaries


def _as_points(P, name: str) -> np.ndarray:
    P = np.array(P, dtype=np.float64).reshape(-1, 2) if np.size(P) else np.zeros((0, 2))
    if not np.isfinite(P).all():
        raise ValueError(f"{name} must be finite")
    return P


def _cage(cage) -> np.ndarray:
    C = _as_points(cage, "cage")
    msg = check_cage(C)
    if msg:
        raise ValueError(f"cage {msg}")
    return C


def _scale(C: np.ndarray) -> float:
    return float(np.ptp(C, axis=0).max())


def _edge_frames(C: np.ndarray, X: np.ndarray):
    """Per point and edge k (from ``C[k]`` to ``C[k+1]``): ``s = C[k] - x``, ``sn``
    (``C[k+1] - x``), their lengths, cross and dot products; (n, m) arrays."""
    s = C[None, :, :] - X[:, None, :]
    sn = np.roll(s, -1, axis=1)
    r = np.hypot(s[..., 0], s[..., 1])
    rn = np.roll(r, -1, axis=1)
    cross = s[..., 0] * sn[..., 1] - s[..., 1] * sn[..., 0]
    dot = (s * sn).sum(axis=2)
    return r, rn, cross, dot


def _half_tan(r, rn, cross, dot):
    """tan(alpha / 2) of the signed angle alpha between ``s`` and ``sn``, in the form
    without cancellation: sin / (1 + cos) where cos > 0, (1 - cos) / sin elsewhere. On
    the edge (alpha = +-pi) the value is infinite; the callers handle those points."""
    rr = r * rn
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(dot > 0, cross / (rr + dot), (rr - dot) / cross)


def _nearest_on_edges(C: np.ndarray, X: np.ndarray):
    """The nearest point of each edge to each point, (n, m, 2), and its distance (n, m)."""
    E = np.roll(C, -1, axis=0) - C
    d = X[:, None, :] - C[None]
    t = np.clip((d * E[None]).sum(axis=2) / (E * E).sum(axis=1)[None], 0.0, 1.0)
    Q = C[None] + t[..., None] * E[None]
    return Q, np.hypot(*(X[:, None, :] - Q).transpose(2, 0, 1))


def _snapped(C: np.ndarray, X: np.ndarray, tol: float) -> np.ndarray:
    """``X`` with every point within ``tol`` of the cage moved onto it (onto a vertex
    within ``tol`` of one, else onto the nearest edge), so that the boundary cases below
    see one consistent position."""
    Q, dist = _nearest_on_edges(C, X)
    k = dist.argmin(axis=1)
    near = dist[np.arange(len(X)), k] <= tol
    if not near.any():
        return X
    X = X.copy()
    X[near] = Q[near, k[near]]
    dv = np.hypot(*(X[near, None, :] - C[None]).transpose(2, 0, 1))
    j = dv.argmin(axis=1)
    at = dv[np.arange(len(j)), j] <= tol
    idx = np.flatnonzero(near)[at]
    X[idx] = C[j[at]]
    return X


def _on_boundary(r, rn, cross, dot, tol):
    """(n, m) masks: the point lies on vertex k; the point lies inside edge k."""
    at_vertex = r <= tol
    on_edge = (np.abs(cross) <= tol * np.maximum(rn + r, tol)) & (dot < 0)
    return at_vertex, on_edge & ~at_vertex & ~np.roll(at_vertex, -1, axis=1)


def winding(cage, points) -> np.ndarray:
    """Winding number of the cage around each point: 0 outside, +-1 inside a simple cage
    (the sign is its orientation); about +-0.5 on the cage (+-1 or 0 on an edge, by the
    rounding of the point's side: test distances where that matters)."""
    C, X = _as_points(cage, "cage"), _as_points(points, "points")
    return _by_chunks(_winding_rows, C, X, 0.0)


def _winding_rows(C: np.ndarray, X: np.ndarray, tol: float) -> np.ndarray:
    r, rn, cross, dot = _edge_frames(C, X)
    return np.arctan2(cross, dot).sum(axis=1) / (2.0 * np.pi)


def mvc(cage, points, *, tol: float = 1e-9) -> np.ndarray:
    """Mean value coordinates (Hormann & Floater 2006) of ``points`` in ``cage``.

    ``w_k = (tan(alpha_(k-1) / 2) + tan(alpha_k / 2)) / r_k`` with signed angles, so any
    simple polygon works and points outside it too. A point on a vertex gets that
    vertex's unit row, a point on an edge the linear weights of the edge's ends.

    Parameters
    ----------
    cage : (m, 2) polygon, either orientation, not closed. points : (n, 2).
    tol : distance (relative to the cage's size) under which a point is on the cage.

    Returns
    -------
    W : (n, m) float, rows summing to 1 with ``W @ cage == points``.
    """
    C, X = _cage(cage), _as_points(points, "points")
    return _by_chunks(_mvc_rows, C, X, tol * _scale(C))


def _by_chunks(rows, C: np.ndarray, X: np.ndarray, tol: float):
    """``rows(C, X, tol)`` over blocks of ``X`` (the (n, m) temporaries stay small)."""
    if len(X) <= _CHUNK:
        return rows(C, X, tol)
    parts = [rows(C, X[i:i + _CHUNK], tol) for i in range(0, len(X), _CHUNK)]
    if isinstance(parts[0], tuple):
        return tuple(np.concatenate(p) for p in zip(*parts))
    return np.concatenate(parts)


def _mvc_rows(C: np.ndarray, X: np.ndarray, tol: float) -> np.ndarray:
    X = _snapped(C, X, tol)
    r, rn, cross, dot = _edge_frames(C, X)
    at_vertex, on_edge = _on_boundary(r, rn, cross, dot, tol)
    t = _half_tan(r, rn, cross, dot)
    special = at_vertex.any(axis=1) | on_edge.any(axis=1)
    t[special] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (np.roll(t, 1, axis=1) + t) / r
    w[special] = 0.0
    W = w / np.where(special, 1.0, w.sum(axis=1))[:, None]
    rows, k = np.nonzero(on_edge & ~at_vertex.any(axis=1, keepdims=True))
    rows, first = np.unique(rows, return_index=True)  # a point on two edges is on their vertex
    k = k[first]
    kn = (k + 1) % len(C)
    a, b = r[rows, k], rn[rows, k]
    W[rows, k], W[rows, kn] = b / (a + b), a / (a + b)
    rows, k = np.nonzero(at_vertex)
    rows, first = np.unique(rows, return_index=True)
    W[rows] = 0.0
    W[rows, k[first]] = 1.0
    return W


def _orientation(C: np.ndarray) -> float:
    """+1 where the cage runs counter-clockwise in (x, y) (left turns are convex)."""
    return 1.0 if ring_area(C) > 0 else -1.0


def green(cage, points, *, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Green coordinates (Lipman, Levin & Cohen-Or 2008) of ``points`` inside ``cage``.

    From Green's third identity for a harmonic ``u`` in the cage ``Omega`` with
    ``G = log|xi - x| / (2 pi)`` and ``n`` the outward normal,
    ``u(x) = int u dG/dn - int G du/dn``; ``u`` linear along each edge gives
    ``phi_j = int hat_j dG/dn`` (over the two edges at vertex j) and
    ``psi_k = -int_(edge k) G``, both in closed form (module docs in
    ``docs/algorithms.md``). ``x = sum phi_j v_j + sum psi_k n_k`` and ``sum phi = 1``.

    A point on the cage gets the limit from inside (its edge subtends pi, a vertex with
    interior angle beta subtends 2 pi - beta), so the map is continuous up to the cage.

    Returns
    -------
    phi : (n, m) vertex coordinates. psi : (n, m) edge coordinates, edge k from vertex k
    to vertex k + 1, for the outward unit normals of the rest cage.

    Raises
    ------
    ValueError
        A point outside the cage (the coordinates reproduce nothing there).
    """
    C, X = _cage(cage), _as_points(points, "points")
    phi, psi, outside = _by_chunks(_green_rows, C, X, tol * _scale(C))
    if outside.any():
        raise ValueError(f"green coordinates need points inside the cage: {int(outside.sum())} "
                         f"of {len(X)} lie outside (the first at {X[outside][0].tolist()})")
    return phi, psi


def _green_rows(C: np.ndarray, X: np.ndarray, tol: float):
    sigma = _orientation(C)
    E = np.roll(C, -1, axis=0) - C
    ln = np.hypot(E[:, 0], E[:, 1])
    T = E / ln[:, None]
    N = sigma * (T @ _QUARTER)  # outward unit normals
    X = _snapped(C, X, tol)
    r, rn, cross, dot = _edge_frames(C, X)
    at_vertex, on_edge = _on_boundary(r, rn, cross, dot, tol)
    d0 = C[None] - X[:, None]
    a = (d0 * T[None]).sum(axis=2)  # the edge runs over u in [a, a + l] of its line
    h = (d0 * N[None]).sum(axis=2)  # distance of the line, > 0 seen from inside
    b = a + ln
    I0 = np.arctan2(h * ln, h * h + a * b)  # the angle the edge subtends
    on_line = at_vertex | np.roll(at_vertex, -1, axis=1) | on_edge
    I0 = np.where(on_edge, np.pi, I0)
    turn = np.arctan2(sigma * (np.roll(E, 1, axis=0)[:, 0] * E[:, 1] - np.roll(E, 1, axis=0)[:, 1] * E[:, 0]),
                      (np.roll(E, 1, axis=0) * E).sum(axis=1))
    outer = np.pi + turn  # 2 pi - interior angle, at each vertex
    I0 = np.where(at_vertex, outer[None] / 2.0, I0)  # the edge leaving the vertex
    I0 = np.where(np.roll(at_vertex, -1, axis=1), np.roll(outer, -1)[None] / 2.0, I0)  # the one arriving
    h = np.where(on_line, 0.0, h)
    r2, rn2 = r * r, rn * rn
    with np.errstate(divide="ignore", invalid="ignore"):
        logr2 = np.where(r2 > 0, np.log(r2), 0.0)
        logrn2 = np.where(rn2 > 0, np.log(rn2), 0.0)
    I1 = 0.5 * h * (logrn2 - logr2)  # int u h / (u^2 + h^2) du
    outside = I0.sum(axis=1) < np.pi  # the angles sum to 2 pi inside, 0 outside
    first = (I1 - a * I0) / ln  # int (s / l) dG/dn, times 2 pi
    phi = (I0 - first + np.roll(first, 1, axis=1)) / (2.0 * np.pi)
    psi = -(b * logrn2 - a * logr2 - 2.0 * ln + 2.0 * h * I0) / (4.0 * np.pi)
    return phi, psi, outside


# -- harmonic coordinates -------------------------------------------------------------------------


@dataclass
class HarmonicMesh:
    """A triangle mesh of the cage's interior: ``V`` (k, 2), ``F`` (t, 3), and the cage's
    piecewise linear functions at the boundary vertices ``b``: ``bw`` (len(b), m)."""

    V: np.ndarray
    F: np.ndarray
    b: np.ndarray
    bw: np.ndarray


def harmonic_mesh(cage, *, max_edge: float | None = None, min_angle: float = 30.0) -> HarmonicMesh:
    """Quality triangulation (Shewchuk's Triangle) of the cage's interior, with every
    cage edge split into equal pieces of at most ``max_edge`` (default: the cage's size
    over 80) and no further vertex on the cage, so the boundary data is exact."""
    import triangle  # lazy: Triangle loads only where harmonic coordinates are made

    C = _cage(cage)
    m = len(C)
    h = _scale(C) / 80.0 if max_edge is None else float(max_edge)
    E = np.roll(C, -1, axis=0) - C
    pieces = np.maximum(1, np.ceil(np.hypot(E[:, 0], E[:, 1]) / h - 1e-9).astype(int))
    t = np.concatenate([np.arange(p) / p for p in pieces])
    k = np.repeat(np.arange(m), pieces)
    B = C[k] + t[:, None] * E[k]
    nb = len(B)
    bw = np.zeros((nb, m))
    bw[np.arange(nb), k] = 1.0 - t
    bw[np.arange(nb), (k + 1) % m] += t
    seg = np.stack([np.arange(nb), (np.arange(nb) + 1) % nb], axis=1)
    area = h * h * np.sqrt(3.0) / 4.0
    out = triangle.triangulate({"vertices": B, "segments": seg}, f"pq{min_angle:g}a{area:.6g}YYQ")
    V = np.asarray(out["vertices"], np.float64)
    if not np.array_equal(V[:nb], B):
        raise ValueError("cage: the triangulation of its interior moved a boundary vertex")
    return HarmonicMesh(V, np.asarray(out["triangles"], np.int64), np.arange(nb), bw)


def harmonic_weights(V, F, b, bw) -> np.ndarray:
    """Discrete harmonic functions on a mesh: ``W[b] = bw`` and the cotangent Laplacian
    of ``W`` zero at every other vertex; one sparse LU factor, one solve for all the
    columns. Returns (len(V), bw.shape[1])."""
    L = cotangent_laplacian(V, F).tocsr()
    free = np.setdiff1d(np.arange(len(V)), b)
    W = np.zeros((len(V), bw.shape[1]))
    W[b] = bw
    if len(free):
        lu = spla.splu(L[free][:, free].tocsc())
        W[free] = lu.solve(-(L[free][:, b] @ bw))
    return W


def _locate(V: np.ndarray, F: np.ndarray, X: np.ndarray, tol: float = 1e-9):
    """The triangle of ``F`` holding each point and its barycentric coordinates; -1 for a
    point in none. Candidates are the triangles with the 4, then 16, 64, 256 nearest
    centroids (a quality mesh's triangle holding a point is among its nearest few)."""
    from scipy.spatial import cKDTree  # lazy: scipy.spatial costs 0.17 s of every command's start-up

    P = V[F]
    O = P[:, 2]
    e1, e2 = P[:, 0] - O, P[:, 1] - O
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    tri = np.full(len(X), -1)
    lam = np.zeros((len(X), 3))
    tree = cKDTree(P.mean(axis=1))
    todo = np.arange(len(X))
    for k in (4, 16, 64, 256):
        k = min(k, len(F))
        _, cand = tree.query(X[todo], k=k)
        cand = cand.reshape(len(todo), k)
        d = X[todo, None, :] - O[cand]
        l0 = (d[..., 0] * e2[cand, 1] - d[..., 1] * e2[cand, 0]) / det[cand]
        l1 = (e1[cand, 0] * d[..., 1] - e1[cand, 1] * d[..., 0]) / det[cand]
        inside = (l0 >= -tol) & (l1 >= -tol) & (1.0 - l0 - l1 >= -tol)
        hit = inside.any(axis=1)
        j = inside.argmax(axis=1)
        rows = np.arange(len(todo))
        tri[todo[hit]] = cand[rows, j][hit]
        lam[todo[hit], 0], lam[todo[hit], 1] = l0[rows, j][hit], l1[rows, j][hit]
        todo = todo[~hit]
        if not len(todo) or k == len(F):
            break
    lam[:, 2] = 1.0 - lam[:, 0] - lam[:, 1]
    return tri, lam


def harmonic(cage, points, *, mesh: HarmonicMesh | None = None, max_edge: float | None = None) -> np.ndarray:
    """Harmonic coordinates (Joshi et al. 2007) of points inside the cage.

    Solved on ``mesh`` (default :func:`harmonic_mesh`) and interpolated linearly in the
    triangle that holds each point. A layer's mesh vertices are such points: the cage's
    mesh is made from the cage alone, so the layer's own triangles play no part.

    Returns
    -------
    W : (n, m) float, non-negative, rows summing to 1, ``W @ cage == points``.

    Raises
    ------
    ValueError
        A point outside the cage.
    """
    C, X = _cage(cage), _as_points(points, "points")
    hm = harmonic_mesh(C, max_edge=max_edge) if mesh is None else mesh
    Wv = harmonic_weights(hm.V, hm.F, hm.b, hm.bw)
    tri, lam = _locate(hm.V, hm.F, X, tol=1e-9)
    if (tri < 0).any():
        bad = X[tri < 0]
        raise ValueError(f"harmonic coordinates need points inside the cage: {len(bad)} of {len(X)} "
                         f"lie outside (the first at {bad[0].tolist()})")
    return np.einsum("nc,ncm->nm", lam, Wv[hm.F[tri]])


# -- the cage map -------------------------------------------------------------------------------


class CageMap:
    """Points written once in coordinates of a rest cage; ``apply`` poses them.

    ``apply(C') = A @ C' + B @ (C' J)`` (``B`` only for ``green``; ``J`` a quarter turn),
    computed as one product of ``W = [A | B]`` (n, m or 2m) with the stacked cage.

    Parameters
    ----------
    cage : (m, 2) rest cage. points : (n, 2) rest points (a layer's mesh vertices).
    kind : ``"green"``, ``"mvc"`` or ``"harmonic"``.
    options : passed to the coordinates' function (``tol``; ``max_edge`` for harmonic).
    """

    def __init__(self, cage, points, kind: str = "green", **options):
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        self.cage = _cage(cage)
        self.points = _as_points(points, "points")
        self.kind = kind
        if kind == "green":
            phi, psi = green(self.cage, self.points, **options)
            E = np.roll(self.cage, -1, axis=0) - self.cage
            D = (np.roll(np.eye(len(E)), 1, axis=1) - np.eye(len(E))) / np.hypot(E[:, 0], E[:, 1])[:, None]
            sigma = _orientation(self.cage)  # s_k n'_k = sigma (e'_k J) / |e_k|
            self.W = np.ascontiguousarray(np.hstack([phi, sigma * (psi @ D)]))
        else:
            self.W = np.ascontiguousarray((mvc if kind == "mvc" else harmonic)(self.cage, self.points, **options))

    def stacked(self, cage) -> np.ndarray:
        """The right-hand side of ``apply``: the cage, and for ``green`` its quarter turn."""
        C = np.asarray(cage, np.float64).reshape(-1, 2)
        if C.shape != self.cage.shape:
            raise ValueError(f"cage must have {len(self.cage)} points like the rest cage, got {len(C)}")
        return np.vstack([C, C @ _QUARTER]) if self.kind == "green" else C

    def apply(self, cage) -> np.ndarray:
        """The points carried by the posed ``cage`` (m, 2): (n, 2)."""
        return self.W @ self.stacked(cage)

    def operator(self) -> np.ndarray:
        """The (2n, 2m) matrix taking the cage's x then y coordinates to the points'."""
        m = len(self.cage)
        A, B = self.W[:, :m], (self.W[:, m:] if self.kind == "green" else np.zeros_like(self.W))
        return np.block([[A, B], [-B, A]])


# -- landmark fitting -----------------------------------------------------------------------------


def _similarity_laplacian(C: np.ndarray) -> np.ndarray:
    """(2m, 2m) rows ``delta'_i - (alpha_i e'_i + beta_i e'_i J)`` over the cage's x then
    y coordinates, with ``delta_i = v_i - (v_(i-1) + v_(i+1)) / 2``, ``e_i = v_(i+1) -
    v_(i-1)`` and ``alpha, beta`` the rest cage's: zero for every similarity of it."""
    m = len(C)
    I = np.eye(m)
    Nx, Pv = np.roll(I, 1, axis=1), np.roll(I, -1, axis=1)  # rows pick v_(i+1), v_(i-1)
    Dl = I - (Nx + Pv) / 2.0
    Ed = Nx - Pv
    d, e = Dl @ C, Ed @ C
    e2 = (e * e).sum(axis=1)
    alpha = (d * e).sum(axis=1) / e2
    beta = (d * (e @ _QUARTER)).sum(axis=1) / e2  # e J = (e_y, -e_x)
    a, bt = alpha[:, None] * Ed, beta[:, None] * Ed
    # x row: d_x - alpha e_x - beta e_y; y row: d_y - alpha e_y + beta e_x
    return np.block([[Dl - a, -bt], [bt, Dl - a]])


def _gradient_jumps(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """(4 p, 2 k) rows: the jump of a map's 2x2 gradient across each of the p interior
    edges of the mesh (V, F), from the map's x then y values at the k vertices, weighted
    by the root of the two triangles' mean area (so the squared norm is an integral, px^2).
    Zero exactly for affine maps."""
    k, T = len(V), len(F)
    Einv = np.linalg.inv(np.stack([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]], axis=-1))  # (T, 2, 2)
    # d u / d x_c = sum_j (u_j - u_0) Einv[j - 1, c]: per corner the coefficient of u at it
    coef = np.stack([-Einv[:, 0] - Einv[:, 1], Einv[:, 0], Einv[:, 1]], axis=1)  # (T, 3 corners, 2 columns)
    rows, cols, vals = [], [], []
    for comp in range(2):  # the map's x, then y
        for c in range(2):  # d/dx, d/dy
            r = np.repeat(np.arange(T) * 4 + comp * 2 + c, 3)
            rows.append(r)
            cols.append(F.ravel() + comp * k)
            vals.append(coef[:, :, c].ravel())
    G = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(4 * T, 2 * k))
    half = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    owner = np.tile(np.arange(T), 3)
    order = np.lexsort((half[:, 1], half[:, 0]))
    h, o = half[order], owner[order]
    same = (h[1:] == h[:-1]).all(axis=1)
    t, u = o[:-1][same], o[1:][same]
    area = 0.5 * np.abs(np.linalg.det(np.stack([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]], axis=-1)))
    w = np.sqrt(0.5 * (area[t] + area[u]))
    rows = np.arange(4 * len(t))
    jump = sp.csr_matrix((np.concatenate([np.repeat(w, 4), -np.repeat(w, 4)]),
                          (np.concatenate([rows, rows]),
                           np.concatenate([(t[:, None] * 4 + np.arange(4)).ravel(),
                                           (u[:, None] * 4 + np.arange(4)).ravel()]))),
                         shape=(len(rows), 4 * T))
    return jump @ G


class CageFit:
    """What landmark fitting needs of a rest cage, made once per cage and kind: the
    smoothness energy ``H`` over the cage's x then y coordinates (2m, 2m).

    ``H`` is the squared jump of the cage map's gradient across the edges of a coarse
    mesh of the cage's interior (a discrete ``int |f''|^2``, as Weber et al. 2009 use for
    point-to-point Cauchy-Green), plus ``1e-3`` times the cage's similarity-invariant
    Laplacian (it picks the similarity among the affine maps too few pins leave free).
    Both vanish on every similarity of the cage."""

    def __init__(self, cage, kind: str = "green", *, samples: int = 12, **options):
        self.cage = _cage(cage)
        self.kind = kind
        hm = harmonic_mesh(self.cage, max_edge=_scale(self.cage) / samples, min_angle=25.0)
        A = CageMap(self.cage, hm.V, kind, **options).operator()  # (2k, 2m)
        D = _gradient_jumps(hm.V, hm.F) @ A
        R = _similarity_laplacian(self.cage)
        self.H = D.T @ D + 1e-3 * (R.T @ R)


def fit_cage(cage, kind: str, pins_rest, pins_target, *, smooth: float = 0.0, fixed=None,
             cage_map: CageMap | None = None, fit: CageFit | None = None, **options) -> np.ndarray:
    """The cage whose map carries the pins to their targets, as smooth as it can be.

    Minimises the smoothness energy ``E(C')`` of :class:`CageFit` with the pins held at
    their targets (``smooth == 0``), or ``|A C' - targets|^2 + smooth * E(C')`` where
    ``smooth > 0`` lets them give (``A`` the pins' cage map). One dense linear solve (the
    unknowns are the cage's 2m coordinates). ``E`` is zero on similarities, so a
    similarity of the pins gives that similarity of the cage; for ``green`` this is the
    point-to-point Cauchy-Green fit of Weber, Ben-Chen & Gotsman (2009, section 5).

    Parameters
    ----------
    cage : (m, 2) rest cage. kind : coordinates, as :class:`CageMap`.
    pins_rest, pins_target : (p, 2) pins and their targets.
    smooth : weight of the smoothness term against the pins' squared distances (px^2);
        0 holds the pins exactly (least squares where they ask for more than the cage
        can give).
    fixed : optional ``(indices, positions)`` of cage vertices posed directly (handles a
        pose moves); they are held exactly.
    cage_map, fit : the pins' :class:`CageMap` and the cage's :class:`CageFit`, when
        already made (a drag makes them once and solves at each move).

    Returns
    -------
    (m, 2) posed cage.
    """
    C = _cage(cage)
    m = len(C)
    Pt = _as_points(pins_target, "pins_target")
    cmap = CageMap(C, pins_rest, kind, **options) if cage_map is None else cage_map
    H = (CageFit(C, kind, **options) if fit is None else fit).H
    A = cmap.operator()
    y = np.concatenate([Pt[:, 0], Pt[:, 1]])
    if fixed is not None and len(fixed[0]):
        idx = np.asarray(fixed[0], int)
        pos = _as_points(fixed[1], "fixed positions")
        S = np.zeros((len(idx), m))
        S[np.arange(len(idx)), idx] = 1.0
        Z = np.zeros_like(S)
        A = np.vstack([A, np.block([[S, Z], [Z, S]])])
        y = np.concatenate([y, pos[:, 0], pos[:, 1]])
    x0 = np.concatenate([C[:, 0], C[:, 1]])
    tiny = 1e-9 * np.trace(H) / (2 * m)  # a pull to the rest cage, for what no pin fixes
    H = H + tiny * np.eye(2 * m)
    if smooth > 0:
        x = scipy.linalg.solve(A.T @ A + smooth * H, A.T @ y + smooth * tiny * x0, assume_a="pos")
    else:
        k = len(y)
        K = np.block([[H, A.T], [A, np.zeros((k, k))]])
        x = scipy.linalg.lstsq(K, np.concatenate([tiny * x0, y]))[0][: 2 * m]
    return np.stack([x[:m], x[m:]], axis=1)


# -- checks and automatic cages -------------------------------------------------------------------


def _segments_cross(P: np.ndarray) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges of the closed ring ``P`` that touch or
    cross, or of adjacent edges that fold back onto each other; None if none."""
    m = len(P)
    A, B = P, np.roll(P, -1, axis=0)
    i, j = np.triu_indices(m, 1)

    def orient(p, q, r):
        return np.sign((q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))

    def within(p, q, r):  # r on segment pq, given collinear
        return ((np.minimum(p[..., 0], q[..., 0]) <= r[..., 0]) & (r[..., 0] <= np.maximum(p[..., 0], q[..., 0]))
                & (np.minimum(p[..., 1], q[..., 1]) <= r[..., 1]) & (r[..., 1] <= np.maximum(p[..., 1], q[..., 1])))

    a, b, c, d = A[i], B[i], A[j], B[j]
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    hit = ((o1 * o2 < 0) & (o3 * o4 < 0)) | ((o1 == 0) & within(a, b, c)) | ((o2 == 0) & within(a, b, d)) \
        | ((o3 == 0) & within(c, d, a)) | ((o4 == 0) & within(c, d, b))
    adjacent = (j == i + 1) | ((i == 0) & (j == m - 1))
    # adjacent edges share one vertex: they conflict only where they overlap (fold back)
    shared_next = j == i + 1  # b == c
    fold = np.where(shared_next, (o2 == 0) & (((d - b) * (a - b)).sum(axis=-1) > 0),
                    (o1 == 0) & (((c - a) * (b - a)).sum(axis=-1) > 0))  # i == 0, j == m - 1: d == a
    bad = np.where(adjacent, fold, hit)
    k = np.flatnonzero(bad)
    return (int(i[k[0]]), int(j[k[0]])) if len(k) else None


def check_cage(points) -> str | None:
    """What is wrong with a cage's points, in words (the caller names the scene path), or
    None for a usable cage: at least 3 finite points within +-MAX_COORD px, no edge of
    zero length, a non-zero area, no two edges touching or crossing."""
    try:
        P = np.array(points, dtype=np.float64)
    except (TypeError, ValueError):
        return "needs a list of [x, y] points"
    if P.ndim != 2 or P.shape[1] != 2:
        return "needs a list of [x, y] points"
    if len(P) < 3:
        return f"has {len(P)} point{'s' if len(P) != 1 else ''}, needs at least 3"
    if not np.isfinite(P).all():
        k = int(np.flatnonzero(~np.isfinite(P).all(axis=1))[0])
        return f"point {k} is not finite ({P[k].tolist()})"
    if (np.abs(P) > MAX_COORD).any():
        k = int(np.flatnonzero((np.abs(P) > MAX_COORD).any(axis=1))[0])
        return f"point {k} {P[k].tolist()} is out of range (at most {MAX_COORD:g} px from the origin)"
    E = np.roll(P, -1, axis=0) - P
    short = np.flatnonzero(np.hypot(E[:, 0], E[:, 1]) <= 1e-9 * max(_scale(P), 1.0))
    if len(short):
        return f"points {short[0]} and {(short[0] + 1) % len(P)} coincide"
    pair = _segments_cross(P)
    if pair:
        i, j = pair
        return f"crosses itself (edge {i}-{(i + 1) % len(P)} meets edge {j}-{(j + 1) % len(P)})"
    if abs(ring_area(P)) <= 1e-12 * max(_scale(P), 1.0) ** 2:
        return "encloses no area"
    return None


def check_encloses(cage, points) -> str | None:
    """What is wrong with a usable cage (see :func:`check_cage`) around ``points`` (a
    layer's mesh vertices), in words, or None where it holds every point inside (points
    on the cage count as inside)."""
    C, X = _as_points(cage, "cage"), _as_points(points, "points")
    if not len(X):
        return None
    out = np.flatnonzero(np.abs(winding(C, X)) < 0.25)
    if len(out):  # a point on the cage may count either way in the winding number
        near = _by_chunks(lambda C, X, tol: _nearest_on_edges(C, X)[1].min(axis=1), C, X[out], 0.0)
        out = out[near > 1e-9 * _scale(C)]
    if not len(out):
        return None
    return (f"leaves {len(out)} of the layer's {len(X)} mesh vertices outside "
            f"(the first at [{X[out[0], 0]:g}, {X[out[0], 1]:g}])")


def auto_cage(mask, n: int = 16, offset: float = 10.0) -> np.ndarray:
    """A cage of about ``n`` vertices around the true pixels of ``mask`` (H, W), at least
    about ``offset`` px outside them, in the mask's pixel coordinates (pixel centres at
    integers); counter-clockwise on screen.

    The mask is grown by ``offset`` (Euclidean distance), its outline (the convex hull
    where it is in several pieces) simplified by Douglas-Peucker with the tolerance that
    leaves about ``n`` vertices; the outline is first grown by that tolerance more, so
    the simplified cage keeps its distance."""
    import cv2  # lazy: OpenCV loads only where a cage is made from a mask

    M = np.asarray(mask, bool)
    if not M.any():
        raise ValueError("auto_cage: the mask is empty")
    if n < 3 or offset < 0:
        raise ValueError(f"auto_cage: needs n >= 3 and offset >= 0, got n={n}, offset={offset}")
    ring = None
    tol = 0.0
    for _ in range(2):
        ring = _grown_outline(cv2, M, float(offset) + tol)
        tol = _tolerance_for(cv2, ring, n)
    Q = cv2.approxPolyDP(ring.astype(np.float32).reshape(-1, 1, 2), tol, True)[:, 0, :].astype(np.float64)
    if len(Q) < 3:
        Q = ring
    return Q if ring_area(Q) < 0 else Q[::-1]  # y down: negative (x, y) area is counter-clockwise on screen


def _grown_outline(cv2, M: np.ndarray, grow: float) -> np.ndarray:
    pad = int(np.ceil(grow)) + 2
    Mp = np.pad(M, pad).astype(np.uint8)
    dist = cv2.distanceTransform(1 - Mp, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    G = (dist <= grow).astype(np.uint8)
    contours, _ = cv2.findContours(G, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    pts = [c[:, 0, :] for c in contours]
    ring = pts[0] if len(pts) == 1 else cv2.convexHull(np.concatenate(pts))[:, 0, :]
    return ring.astype(np.float64) - pad


def _tolerance_for(cv2, ring: np.ndarray, n: int) -> float:
    """The Douglas-Peucker tolerance that leaves at most ``n`` vertices (bisection)."""
    R = ring.astype(np.float32).reshape(-1, 1, 2)
    lo, hi = 0.0, float(np.ptp(ring, axis=0).max())
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if len(cv2.approxPolyDP(R, mid, True)) > n:
            lo = mid
        else:
            hi = mid
    return hi
