"""Relaxed ARAP: remove fold-overs left by point-constrained ARAP (garment paper §3.1.2).

Point constraints dragged against the local rotation can leave a few triangles folded
(signed area flipped or zero) at the converged ARAP minimum, typically around a pin at a
thin tip of the shape. Two stages, the second only for what the first leaves:

1. **Similarity relaxation** (the paper's relaxed ARAP). The cells of the folded
   triangles' vertices and a ring of neighbours use a similarity ``s_i R_i``, with the
   optimal scale ``s_i = |q_i| / sum_j w_ij |e_ij|^2`` clamped to ``[s_min, s_max]``,
   instead of a rotation, so the region can shrink instead of folding; every other cell
   keeps the rotation it has in the given ``U``, so the change stays near the folds
   (re-estimating them would go on iterating ARAP over the whole pose) and the cells a
   pin angle turned stay turned. Only the right-hand side of the global step changes: the
   ARAP factor is reused, never refactorised. While folds remain (``rounds``) the region
   takes in the new folds and grows, and ``s_min`` halves. The result is kept only if it
   has no fold left: otherwise stage 2 starts from the ARAP result, as a partial
   relaxation moves the region (8 px, 20 px away from the folds, on T-rex ``roar``)
   without making the untangling easier.
2. **Untangling** of what is still folded: the free vertices of a region around the
   folds (3, 6, 12 rings with the outer ring fixed, then the whole mesh; mesh-boundary
   vertices inside a region are free, pins and pinless components fixed) minimise the
   foldover-free energy of Garanzha, Kaporin, Kudryavtseva, Protais, Ray and Sokolov,
   "Foldover-free maps in 50 lines of code" (SIGGRAPH 2021)::

       E_eps = sum_t A_t [(1 - theta) |J_t|^2 + theta (1 + det J_t^2)] / chi(det J_t, eps)
       chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2,   theta = 1/128

   (``J_t`` the rest-to-deformed Jacobian of triangle t, ``A_t`` its rest area), by
   projected Newton steps (per-triangle 4x4 Hessians clamped to positive semi-definite,
   one sparse solve of the region's small system per step: this is not the ARAP matrix,
   which is never refactorised; steps of at most 2 typical edge lengths), lowering
   ``eps`` by the paper's rule ``eps <- 2 sqrt(mu (mu - D_min))``,
   ``mu = (1 - sigma) chi(D_min, eps)``, until every determinant is positive, then at
   ``eps = 1e-10`` (a barrier: the orientation is kept) until the energy settles.
   ``sigma >= 0.85`` here rather than the paper's 0.1 (measured on 109 synthetic drags
   that need this stage: same success, about 15x faster).

Both stages keep every pin exactly on its target and never move a component without
a pin. If a fold cannot be removed (e.g. three pins of one triangle given reversed
targets), the result with the fewest folds is returned, never more than given.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from puppet.deform.arap import ArapData
from puppet.deform.factor import pair_solver as _pair_solver

__all__ = ["folded_triangles", "relax_foldovers", "untangle"]

#: Weight of the area term of the untangling energy (the paper's 2D value).
THETA = 1.0 / 128.0
#: Lower bound of the paper's eps decrease factor sigma (0.1 there; see the module doc).
SIGMA_MIN = 0.85
#: Rings of the local untangling regions, tried in turn before the whole mesh.
UNTANGLE_RINGS = (3, 6, 12)
#: Rounds given to a local region before the next, larger one (its fixed outer ring
#: may leave no fold-free solution).
LOCAL_ROUNDS = 6
#: Untangling ends once fold-free and a round lowers the energy by less than this
#: fraction. The rounds after the first fold-free one pull back what the first steps
#: inflated (a thin tip flung 230 px out on trex-cutout ``reach`` without them).
POLISH_TOL = 1e-3
#: Longest Newton step of a vertex, in typical edge lengths of the region.
STEP_EDGES = 2.0


def _areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Twice the signed areas (m,), by 1-D gathers (4x faster than gathering rows)."""
    x, y = V[:, 0], V[:, 1]
    i, j, k = F[:, 0], F[:, 1], F[:, 2]
    x0, y0 = x.take(i), y.take(i)
    return (x.take(j) - x0) * (y.take(k) - y0) - (y.take(j) - y0) * (x.take(k) - x0)


def folded_triangles(V_rest, U, F) -> np.ndarray:
    """Triangles whose signed area changed sign or vanished.

    Parameters
    ----------
    V_rest : (n, 2) float
        Rest positions.
    U : (n, 2) float
        Deformed positions.
    F : (m, 3) int
        Triangles.

    Returns
    -------
    idx : (j,) int
        Indices into ``F`` with ``area_rest * area_deformed <= 0``; triangles degenerate
        at rest are never counted.
    """
    F = np.asarray(F)
    a0 = _areas(np.asarray(V_rest, float), F)
    a1 = _areas(np.asarray(U, float), F)
    return np.flatnonzero((a0 * a1 <= 0) & (a0 != 0))


def _grow(F: np.ndarray, mask: np.ndarray, rings: int) -> np.ndarray:
    """``mask`` (n,) bool plus ``rings`` rings of neighbours through the triangles."""
    mask = mask.copy()
    for _ in range(rings):
        mask[F[mask[F].any(axis=1)].ravel()] = True
    return mask


def relax_foldovers(data: ArapData, U, bc, *, rings: int = 1, s_min: float = 0.5, s_max: float = 1.5,
                    iterations: int = 20, rounds: int = 3, untangle_folds: bool = True) -> np.ndarray:
    """Remove folded triangles from an ARAP result: bounded-scale similarity cells, then untangling.

    Parameters
    ----------
    data : ArapData
        The group's ARAP precomputation; its factor is reused, never refactorised.
    U : (n, 2) float
        An ARAP result for the targets ``bc`` (not modified).
    bc : (k, 2) float
        Targets of the pinned vertices ``data.b``.
    rings : int
        Rings of neighbours of the folded triangles' vertices whose cells are relaxed in
        the first round; doubles every further round.
    s_min, s_max : float
        Scale bounds of the relaxed cells in the first round; ``s_min`` halves every
        further round. 0.5 and 1.5: a cell may at first halve or grow by half, so a
        part does not visibly shrink. Measured on 131 folded poses (synthetic drags and
        the T-rex scenes): the similarity rounds alone clear every fold in 19-25 of
        them for any of rings 1-2 and s_min 0.2-0.8; the untangling does the rest.
    iterations : int
        Local/global iterations per similarity round.
    rounds : int
        Similarity rounds while folds remain (0: untangle straight away). Their result is
        used only when it has no fold left. 3: more rounds (8+ rings, ``s_min`` <= 1/8)
        rarely remove the last folds and drift the region.
    untangle_folds : bool
        Run the untangling stage (:func:`untangle`) on folds the similarity rounds leave.

    Returns
    -------
    U : (n, 2) float
        ``U`` itself (the same array, untouched) when nothing is folded, which costs one
        vectorised sign check; otherwise a new array with pins exactly on ``bc`` and
        pinless components at rest.
    """
    U = np.asarray(U, dtype=np.float64)
    V, F = data.V, data.F
    bad = folded_triangles(V, U, F)
    if len(bad) == 0:
        return U
    bc = np.asarray(bc, dtype=np.float64).reshape(-1, 2)
    best = U.copy()
    best[data.b] = bc
    best[data.held] = V[data.held]
    bad = folded_triangles(V, best, F)
    if data.factor is not None and rounds > 0 and len(bad):
        X, left = _similarity_rounds(data, best, bc, bad, rings, s_min, s_max, iterations, rounds)
        if len(left) == 0:  # a partial relaxation only drifts the region: not kept
            best, bad = X, left
    if untangle_folds and len(bad):
        start, seed, tried = best, bad, []
        for k in UNTANGLE_RINGS + (None,):
            move = _untangle_region(data, seed, k)
            if not move.any() or any(np.array_equal(move, m) for m in tried):
                continue
            tried.append(move)
            X = untangle(V, F, start, np.flatnonzero(move), max_rounds=60 if k is None else LOCAL_ROUNDS)
            left = folded_triangles(V, X, F)
            if len(left) < len(bad):
                best, bad = X, left
            if len(bad) == 0:
                break
    return best


def _similarity_rounds(data: ArapData, U, bc, bad, rings, s_min, s_max, iterations, rounds):
    """Stage 1: local/global rounds with bounded-scale similarity cells around the folds."""
    V, F, free, b = data.V, data.F, data.free, data.b
    region = np.zeros(data.n, bool)
    region[F[bad].ravel()] = True
    region = _grow(F, region, rings)
    xb = (bc[:, 0] - V[b, 0]) + 1j * (bc[:, 1] - V[b, 1])
    q0 = data.S0 + data.S_b @ xb
    rb = data.L_fb @ xb
    rest = np.where(data.S0 > 0, data.S0, 1.0)
    xf = (U[free, 0] - V[free, 0]) + 1j * (U[free, 1] - V[free, 1])
    q = data.S_f @ xf + q0
    r = np.abs(q)
    r[r == 0] = 1.0
    sigma = q / r  # the rotations of U: kept by every cell outside the region
    X, lo = U, s_min
    solve, close = _pair_solver(data.factor, len(free), iterations * rounds)
    try:
        for _ in range(rounds):
            cells = np.flatnonzero(region)
            S_c, q0_c, rest_c = data.S_f[cells], q0[cells], rest[cells]
            for _ in range(iterations):
                qc = S_c @ xf + q0_c
                rc = np.abs(qc)
                rc[rc == 0] = 1.0
                sigma[cells] = qc / rc * np.clip(rc / rest_c, lo, s_max)
                xf = solve(data.R @ (sigma - 1.0) - rb)
            X = U.copy()
            X[free, 0], X[free, 1] = V[free, 0] + xf.real, V[free, 1] + xf.imag
            bad = folded_triangles(V, X, F)
            if len(bad) == 0:
                break
            region[F[bad].ravel()] = True
            rings *= 2
            region = _grow(F, region, rings)
            lo *= 0.5
    finally:
        close()
    return X, bad


def _untangle_region(data: ArapData, bad, rings) -> np.ndarray:
    """Vertices the untangling may move: ``rings`` rings around the folded triangles
    minus the outermost ring (fixed), or everything for ``rings=None``; never pins or
    pinless components. (n,) bool."""
    F = data.F
    if rings is None:
        move = np.ones(data.n, bool)
    else:
        region = np.zeros(data.n, bool)
        region[F[bad].ravel()] = True
        region = _grow(F, region, rings)
        move = region.copy()
        move[F[~region[F].all(axis=1)].ravel()] = False
    move[data.b] = False
    move[data.held] = False
    return move


def _chi(D: np.ndarray, eps: float) -> np.ndarray:
    """``(D + sqrt(eps^2 + D^2)) / 2``, without cancellation for ``D < 0``."""
    h = np.sqrt(eps * eps + D * D)
    return np.where(D > 0, 0.5 * (D + h), 0.5 * eps * eps / np.where(D > 0, 1.0, h - D))


_HD = np.zeros((4, 4))  # Hessian of det J in vec(J) = (J00, J01, J10, J11)
_HD[0, 3] = _HD[3, 0] = 1.0
_HD[1, 2] = _HD[2, 1] = -1.0


class _Untangling:
    """The untangling energy over the triangles that touch the moving vertices."""

    def __init__(self, V, F, U, move):
        n = len(V)
        moving = np.zeros(n, bool)
        moving[move] = True
        F = F[moving[F].any(axis=1)]
        e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        ok = det != 0
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        g0 = np.stack([e2[:, 1], -e2[:, 0]], 1) * inv[:, None]  # rows of [e1 e2]^-1
        g1 = np.stack([-e1[:, 1], e1[:, 0]], 1) * inv[:, None]
        self.M = np.stack([-(g0 + g1), g0, g1], axis=2)  # (t, 2, 3): J[r, c] = sum_v M[c, v] U[v, r]
        self.w = np.abs(det) / max(np.abs(det).sum(), 1e-300)
        self.F, self.U, self.move = F, np.array(U, dtype=np.float64), move
        local = np.full(n, -1, np.int64)
        local[move] = np.arange(len(move))
        dof = local[F][:, :, None]
        self.dof = np.where(dof >= 0, 2 * dof + np.arange(2), -1).reshape(-1, 6)  # (t, 6), -1 fixed
        ii = np.repeat(self.dof, 6, axis=1).ravel()
        jj = np.tile(self.dof, (1, 6)).ravel()
        self.hkeep = (ii >= 0) & (jj >= 0)
        self.hi, self.hj = ii[self.hkeep], jj[self.hkeep]
        self.gkeep = self.dof.ravel() >= 0
        self.ndof = 2 * len(move)
        self.step = STEP_EDGES * float(np.sqrt(np.abs(det).mean()))  # longest step

    def jacobians(self, x) -> np.ndarray:
        self.U[self.move] = x.reshape(-1, 2)
        return np.einsum("tcv,tvr->trc", self.M, self.U[self.F]).reshape(-1, 4)

    @staticmethod
    def _det(j):
        return j[:, 0] * j[:, 3] - j[:, 1] * j[:, 2]

    def dets(self, x) -> np.ndarray:
        return self._det(self.jacobians(x))

    def energy(self, x, eps) -> float:
        j = self.jacobians(x)
        D = self._det(j)
        num = (1 - THETA) * (j * j).sum(1) + THETA * (1 + D * D)
        return float(self.w @ (num / _chi(D, eps)))

    def newton(self, x, eps):
        """Energy, gradient (2p,) and projected Hessian (2p, 2p) csc at ``x``."""
        j = self.jacobians(x)
        D = self._det(j)
        h = np.sqrt(eps * eps + D * D)
        chi, dchi, ddchi = _chi(D, eps), 0.5 + 0.5 * D / h, 0.5 * eps * eps / h ** 3
        gD = np.stack([j[:, 3], -j[:, 2], -j[:, 1], j[:, 0]], 1)
        num = (1 - THETA) * (j * j).sum(1) + THETA * (1 + D * D)
        gn = 2 * (1 - THETA) * j + 2 * THETA * D[:, None] * gD
        gc = dchi[:, None] * gD
        c1, c2, c3 = 1 / chi, num / chi ** 2, 2 * num / chi ** 3
        grad = c1[:, None] * gn - c2[:, None] * gc

        def outer(p, q):
            return p[:, :, None] * q[:, None, :]
        H = (2 * (1 - THETA) * c1)[:, None, None] * np.eye(4) \
            + (2 * THETA * c1)[:, None, None] * (outer(gD, gD) + D[:, None, None] * _HD) \
            - c1[:, None, None] * c1[:, None, None] * (outer(gn, gc) + outer(gc, gn)) \
            - c2[:, None, None] * (ddchi[:, None, None] * outer(gD, gD) + dchi[:, None, None] * _HD) \
            + c3[:, None, None] * outer(gc, gc)
        lam, Q = np.linalg.eigh(H)
        H = (Q * np.maximum(lam, 0.0)[:, None, :]) @ np.transpose(Q, (0, 2, 1))
        w = self.w
        gu = np.einsum("trc,tcv->tvr", (grad * w[:, None]).reshape(-1, 2, 2), self.M).reshape(-1)
        H6 = np.einsum("trcsd,tcv,tdw->tvrws", (H * w[:, None, None]).reshape(-1, 2, 2, 2, 2),
                       self.M, self.M).reshape(-1)
        g = np.bincount(self.dof.ravel()[self.gkeep], weights=gu[self.gkeep], minlength=self.ndof)
        A = sp.csc_matrix((H6[self.hkeep], (self.hi, self.hj)), shape=(self.ndof, self.ndof))
        return float(w @ (num * c1)), g, A


def untangle(V, F, U, move, *, max_rounds: int = 60, newton_steps: int = 5) -> np.ndarray:
    """Move the vertices ``move`` so that no triangle touching them is folded.

    Minimises the foldover-free energy of Garanzha et al. 2021 (module docstring) over
    the positions of ``move``, everything else fixed, by projected Newton steps (a vertex
    moves at most ``STEP_EDGES`` typical edge lengths per step) with the ``eps``
    continuation of the paper, then at ``eps = 1e-10`` until the energy settles
    (``POLISH_TOL``).

    Parameters
    ----------
    V : (n, 2) float
        Rest positions: the reference shape of every triangle.
    F : (m, 3) int
        Triangles.
    U : (n, 2) float
        Deformed positions to start from, folded or not (not modified).
    move : (p,) int
        Vertices allowed to move.
    max_rounds : int
        Cap on the ``eps`` rounds.
    newton_steps : int
        Newton steps per round (each one sparse solve of a (2p, 2p) system).

    Returns
    -------
    X : (n, 2) float
        ``U`` with the moving vertices replaced; every triangle touching them has a
        positive Jacobian determinant when the continuation succeeds, which it does
        whenever the fixed vertices leave a fold-free solution in reach.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    move = np.asarray(move, dtype=np.int64)
    out = np.array(U, dtype=np.float64)
    if len(move) == 0:
        return out
    en = _Untangling(V, F, out, move)
    x = out[move].ravel()
    detmin = en.dets(x).min()
    eps = float(np.sqrt(1e-10 + 0.04 * min(detmin, 0.0) ** 2))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for _ in range(max_rounds):
            x, E_prev, E = _newton_round(en, x, eps, newton_steps)
            detmin = en.dets(x).min()
            if not np.isfinite(x).all() or not np.isfinite(E):
                break
            if detmin > 0 and abs(E_prev - E) <= POLISH_TOL * E:
                break
            sigma = max(1.0 - E / E_prev, SIGMA_MIN)
            mu = (1.0 - sigma) * float(_chi(np.array(detmin), eps))
            eps = max(2.0 * np.sqrt(mu * (mu - detmin)), 1e-10) if detmin < mu else 1e-10
    if np.isfinite(x).all():
        out[move] = x.reshape(-1, 2)
    return out


def _newton_round(en: _Untangling, x, eps, steps):
    """Up to ``steps`` projected Newton steps with Armijo backtracking at fixed ``eps``."""
    E0 = E = en.energy(x, eps)
    for _ in range(steps):
        E, g, A = en.newton(x, eps)
        A = A + sp.identity(en.ndof, format="csc") * (1e-9 * max(A.diagonal().max(), 1e-300))
        p = -spla.spsolve(A, g)
        p /= max(np.abs(p).max() / en.step, 1.0)
        dec = -float(g @ p)
        if not dec > 1e-12 * E:
            break
        t = 1.0
        while t > 1e-8:
            E_new = en.energy(x + t * p, eps)
            if E_new <= E - 1e-4 * t * dec:
                break
            t *= 0.5
        else:
            break
        x = x + t * p
        converged = E - E_new <= 1e-9 * E
        E = E_new
        if converged:
            break
    return x, E0, E
