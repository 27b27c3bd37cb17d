"""Untangling folded triangles: the foldover-free energy of Garanzha et al. 2021.

Garanzha, Kaporin, Kudryavtseva, Protais, Ray and Sokolov, "Foldover-free maps in 50
lines of code" (SIGGRAPH 2021)::

    E_eps = sum_t A_t [(1 - theta) |J_t|^2 + theta (1 + det J_t^2)] / chi(det J_t, eps)
    chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2,   theta = 1/128

(``J_t`` the rest-to-deformed Jacobian of triangle t, ``A_t`` its rest area), minimised
over the moving vertices by projected Newton steps (per-triangle 4x4 Hessians clamped
to positive semi-definite through their closed-form eigensystem, one sparse solve of
the region's system per step, the symbolic factorisation reused between steps; steps of at most ``STEP_EDGES`` typical
edge lengths), lowering ``eps`` by the paper's rule ``eps <- 2 sqrt(mu (mu - D_min))``,
``mu = (1 - sigma) chi(D_min, eps)``, until every determinant is positive, then at
``eps = 1e-10`` (a barrier: the orientation is kept) until the energy settles.
``sigma >= 0.85`` here rather than the paper's 0.1 (measured on 109 synthetic drags
that need this stage: same success, about 15x faster).

Every step is charged to a :class:`puppet.deform.budget.Budget` when one is given; the
minimisation stops where the budget ends and returns where it got to.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from puppet.deform import budget as cost
from puppet.deform.budget import Budget

__all__ = ["untangle", "THETA", "SIGMA_MIN", "POLISH_TOL", "STEP_EDGES"]

#: Weight of the area term of the untangling energy (the paper's 2D value).
THETA = 1.0 / 128.0
#: Lower bound of the paper's eps decrease factor sigma (0.1 there; see the module doc).
SIGMA_MIN = 0.85
#: Untangling ends once fold-free and a round lowers the energy by less than this
#: fraction. The rounds after the first fold-free one pull back what the first steps
#: inflated (a thin tip flung 230 px out on trex-cutout ``reach`` without them).
POLISH_TOL = 1e-3
#: Longest Newton step of a vertex, in typical edge lengths of the region.
STEP_EDGES = 2.0


def _chi(D: np.ndarray, eps: float) -> np.ndarray:
    """``(D + sqrt(eps^2 + D^2)) / 2``, without cancellation for ``D < 0``."""
    h = np.sqrt(eps * eps + D * D)
    return np.where(D > 0, 0.5 * (D + h), 0.5 * eps * eps / np.where(D > 0, 1.0, h - D))


class _Energy:
    """The untangling energy over the triangles that touch the moving vertices.

    With ``d1 = u1 - u0``, ``d2 = u2 - u0`` and ``G = [v1 - v0, v2 - v0]^-1``, the
    Jacobian is ``J = [d1 d2] G``; everything works on per-triangle column arrays.
    """

    def __init__(self, V, F, U, move, n_mesh: int, m_mesh: int):
        n = len(V)
        moving = np.zeros(n, bool)
        moving[move] = True
        F = F[moving[F].any(axis=1)]
        e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        ok = det != 0
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        self.G = np.stack([e2[:, 1] * inv, -e2[:, 0] * inv, -e1[:, 1] * inv, e1[:, 0] * inv])  # (4, t)
        self.w = np.abs(det) / max(np.abs(det).sum(), 1e-300)
        self.F, self.U, self.move = F, np.array(U, dtype=np.float64), move
        local = np.full(n, -1, np.int64)
        local[move] = np.arange(len(move))
        dof = local[F][:, :, None]
        self.dof = np.where(dof >= 0, 2 * dof + np.arange(2), -1).reshape(-1, 6)  # (t, 6), -1 fixed
        self.ndof = 2 * len(move)
        self._pattern()
        self.step = STEP_EDGES * float(np.sqrt(np.abs(det).mean())) if len(F) else 1.0
        t = len(F) / max(m_mesh, 1)
        self.newton_cost = cost.newton_cost(t, len(move) / max(n_mesh, 1), n_mesh)
        self.eval_cost = cost.eval_cost(t, n_mesh)

    def _pattern(self):
        """csc pattern of the region's Hessian (upper triangle) and the slot of every
        entry of the elements' upper triangles (``_IU``, ``_JU``; (21, t) order)."""
        dof = self.dof.T  # (6, t)
        di, dj = dof[_IU].ravel(), dof[_JU].ravel()
        self.hkeep = np.flatnonzero((di >= 0) & (dj >= 0))
        lo = np.minimum(di[self.hkeep], dj[self.hkeep])
        hi = np.maximum(di[self.hkeep], dj[self.hkeep])
        uniq, self.hslot = np.unique(hi * self.ndof + lo, return_inverse=True)  # column-major
        cols, rows = uniq // self.ndof, uniq % self.ndof
        self.indptr = np.zeros(self.ndof + 1, np.int64)
        np.cumsum(np.bincount(cols, minlength=self.ndof), out=self.indptr[1:])
        self.indices = rows
        self.diag = np.flatnonzero(rows == cols)
        self.gdof = dof.ravel()
        self.gkeep = np.flatnonzero(self.gdof >= 0)

    def jacobians(self, x) -> np.ndarray:
        """(4, t): ``(J00, J01, J10, J11)`` with the moving vertices at ``x`` (2p,)."""
        self.U[self.move] = x.reshape(-1, 2)
        F, X, Y = self.F, self.U[:, 0], self.U[:, 1]
        x0, y0 = X.take(F[:, 0]), Y.take(F[:, 0])
        d1x, d1y = X.take(F[:, 1]) - x0, Y.take(F[:, 1]) - y0
        d2x, d2y = X.take(F[:, 2]) - x0, Y.take(F[:, 2]) - y0
        g00, g01, g10, g11 = self.G
        return np.stack([d1x * g00 + d2x * g10, d1x * g01 + d2x * g11,
                         d1y * g00 + d2y * g10, d1y * g01 + d2y * g11])

    @staticmethod
    def _det(j):
        return j[0] * j[3] - j[1] * j[2]

    def dets(self, x) -> np.ndarray:
        return self._det(self.jacobians(x))

    def energy(self, x, eps) -> tuple[float, float]:
        """The energy at ``x`` and the smallest Jacobian determinant there."""
        j = self.jacobians(x)
        D = self._det(j)
        num = (1 - THETA) * np.einsum("ct,ct->t", j, j) + THETA * (1 + D * D)
        return float(self.w @ (num / _chi(D, eps))), float(D.min()) if len(D) else 0.0

    def _spread(self, q: np.ndarray) -> np.ndarray:
        """``B^T q``: (4, ...) per-triangle vectors in vec(J) to (6, ...) on the corners'
        (x, y), with ``J[r, c] = sum_v M[c, v] u_v[r]`` (``M`` from ``G``)."""
        g00, g01, g10, g11 = self.G
        out = np.empty((6,) + q.shape[1:])
        for r in range(2):
            q0, q1 = q[2 * r], q[2 * r + 1]
            out[2 + r] = q0 * g00 + q1 * g01
            out[4 + r] = q0 * g10 + q1 * g11
            out[r] = -(out[2 + r] + out[4 + r])
        return out

    def newton(self, x, eps):
        """Energy, gradient (2p,) and projected Hessian (upper triangle, csc data) at ``x``.

        The element energy ``psi(I, D) = N / chi(D)``, ``N = (1 - theta) I + theta (1 + D^2)``,
        ``I = |J|^2``, ``D = det J``, is isotropic, so its 4x4 Hessian has a closed-form
        eigensystem in the signed SVD ``J = U diag(s1, s2) V^T`` (Smith, De Goes & Kim,
        "Analytic eigensystems for isotropic distortion energies", 2019): twist and flip
        modes with eigenvalues ``2 psi_I +- psi_D`` and a 2x2 scaling block; negative
        eigenvalues are dropped (projected Newton) without any numerical eigensolver.
        """
        j = self.jacobians(x)
        a, b, c, d = j
        D = a * d - b * c
        h = np.sqrt(eps * eps + D * D)
        ch, d1, d2 = _chi(D, eps), 0.5 + 0.5 * D / h, 0.5 * eps * eps / h ** 3
        N = (1 - THETA) * np.einsum("ct,ct->t", j, j) + THETA * (1 + D * D)
        PI = (1 - THETA) / ch
        ND = 2 * THETA * D
        PD = ND / ch - N * d1 / ch ** 2
        PID = -(1 - THETA) * d1 / ch ** 2
        PDD = 2 * THETA / ch - 2 * ND * d1 / ch ** 2 - N * d2 / ch ** 2 + 2 * N * d1 ** 2 / ch ** 3
        grad = 2 * PI * j + PD * np.stack([d, -c, -b, a])  # cof(J) = dD/dJ
        if not (np.isfinite(grad).all() and np.isfinite(PDD).all() and np.isfinite(PID).all()):
            return np.nan, np.full(self.ndof, np.nan), np.full(len(self.indices), np.nan)
        modes, lam = _modes(j, PI, PD, PID, PDD)  # (4, 4, t): vec(J) x mode x triangle
        w = self.w
        modes *= np.sqrt(np.maximum(lam, 0.0) * w)  # H = sum_m (modes m)(modes m)^T, PSD
        P = self._spread(modes)  # (6, 4, t)
        H6 = np.einsum("imt,jmt->ijt", P, P)[_IU, _JU]  # (21, t): upper triangles
        gu = self._spread(grad * w)
        g = np.bincount(self.gdof[self.gkeep], weights=gu.ravel()[self.gkeep], minlength=self.ndof)
        data = np.bincount(self.hslot, weights=H6.ravel()[self.hkeep], minlength=len(self.indices))
        return float(w @ (N / ch)), g, data


_IU, _JU = np.triu_indices(6)  # the 21 entries of a symmetric 6x6 element matrix


def _unit(x, y):
    """(x, y) / |(x, y)|, (1, 0) where both are 0."""
    r = np.hypot(x, y)
    ok = r > 0
    r = np.where(ok, r, 1.0)
    return np.where(ok, x / r, 1.0), np.where(ok, y / r, 0.0)


def _modes(j, PI, PD, PID, PDD):
    """Eigenvectors (4, 4, t): vec(J) x mode x triangle) and eigenvalues (4, t) of the
    element Hessian ``PI * 2 Id + PD * Hess(det) + [gI gD] [[0, PID], [PID, PDD]] [gI gD]^T``.

    Signed SVD ``J = rot(phi) diag(s1, s2) rot(th)``, ``a1 = phi - th``, ``a2 = phi + th``:
    ``U V^T = rot(a2)`` and ``U diag(1, -1) V^T = [[c1, s1], [s1, -c1]]`` (``c1, s1``
    the cosine and sine of ``a1``), so every mode is a combination of those two, the
    twist ``U rot(90) V^T`` and the flip, without trigonometry.
    """
    a, b, c, d = j
    E, Fh, G, Hh = (a + d) / 2, (a - d) / 2, (c + b) / 2, (c - b) / 2
    Q, R = np.hypot(E, Hh), np.hypot(Fh, G)
    s1, s2 = Q + R, Q - R  # signed singular values
    c1, n1 = _unit(Fh, G)  # cos, sin of a1
    c2, n2 = _unit(E, Hh)  # cos, sin of a2
    r = np.sqrt(0.5)
    # scaling block in the basis U diag(1, 0) V^T, U diag(0, 1) V^T:
    # 2 PI Id + PD [[0, 1], [1, 0]] + PID (gI gD^T + gD gI^T) + PDD gD gD^T,
    # gI = (2 s1, 2 s2), gD = (s2, s1)
    base = 2 * PI + 4 * PID * s1 * s2
    A11 = base + PDD * s2 * s2
    A22 = base + PDD * s1 * s1
    A12 = PD + 2 * PID * (s1 * s1 + s2 * s2) + PDD * s1 * s2
    mid, half = (A11 + A22) / 2, np.hypot((A11 - A22) / 2, A12)
    up = A11 >= A22  # eigenvector of mid + half, from the row that cannot vanish
    ca, sa = _unit(np.where(up, A11 - A22 + 2 * half, 2 * A12),
                   np.where(up, 2 * A12, A22 - A11 + 2 * half))
    sym, skew = np.stack([c2, -n2, n2, c2]), np.stack([c1, n1, n1, -c1])
    modes = np.empty((4, 4, len(a)))
    modes[:, 0] = r * np.stack([-n2, -c2, c2, -n2])  # twist
    modes[:, 1] = r * np.stack([-n1, c1, c1, n1])  # flip
    for m, (p, q) in ((2, (ca, sa)), (3, (-sa, ca))):  # scaling: U diag(p, q) V^T
        modes[:, m] = 0.5 * (p + q) * sym + 0.5 * (p - q) * skew
    lam = np.stack([2 * PI + PD, 2 * PI - PD, mid + half, mid - half])
    return modes, lam


class _Solver:
    """Solves with the region's Hessians, one symbolic factorisation for all of them."""

    def __init__(self, en: _Energy):
        self.en, self._q = en, None

    def solve(self, data: np.ndarray, g: np.ndarray) -> np.ndarray:
        en = self.en
        data = data.copy()
        data[en.diag] += 1e-9 * max(float(data[en.diag].max()), 1e-300)
        A = sp.csc_matrix((data, en.indices, en.indptr), shape=(en.ndof, en.ndof))
        try:
            import qdldl

            if self._q is None:
                self._q = qdldl.Solver(A, upper=True)
            else:
                self._q.update(A, upper=True)
            p = self._q.solve(g)
            if np.isfinite(p).all():
                return p
        except (ImportError, ValueError, RuntimeError, TypeError):
            self._q = None
        import scipy.sparse.linalg as spla  # lazy: the fallback only; it loads scipy.linalg

        full = A + sp.triu(A, 1, format="csc").T
        return spla.spsolve(full.tocsc(), g)


def untangle(V, F, U, move, *, max_rounds: int = 60, newton_steps: int = 5,
             budget: Budget | None = None) -> np.ndarray:
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
    budget : Budget, optional
        Work units for the steps (:mod:`puppet.deform.budget`); the minimisation stops
        before a step the budget cannot pay for. ``None``: unbounded.

    Returns
    -------
    X : (n, 2) float
        ``U`` with the moving vertices replaced (finite; ``U`` itself where the
        iteration broke down); every triangle touching them has a positive Jacobian
        determinant when the continuation succeeds, which it does whenever the fixed
        vertices leave a fold-free solution in reach and the budget suffices.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    move = np.asarray(move, dtype=np.int64)
    out = np.array(U, dtype=np.float64)
    if len(move) == 0:
        return out
    budget = Budget(np.inf) if budget is None else budget
    moving = np.zeros(len(V), bool)
    moving[move] = True
    t = np.count_nonzero(moving[F].any(axis=1)) / max(len(F), 1)  # share of the triangles
    setup = cost.setup_cost(t)
    if not budget.affords(setup + cost.newton_cost(t, len(move) / len(V), len(V))
                          + 3 * cost.eval_cost(t, len(V))):
        return out
    en = _Energy(V, F, out, move, len(V), len(F))
    budget.charge(setup + en.eval_cost)
    solver = _Solver(en)
    x = out[move].ravel()
    best = x
    detmin = en.dets(x).min()
    eps = float(np.sqrt(1e-10 + 0.04 * min(detmin, 0.0) ** 2))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        for _ in range(max_rounds):
            x, E_prev, E, detmin, done = _newton_round(en, solver, x, eps, newton_steps, budget)
            if not (np.isfinite(x).all() and np.isfinite(E)):
                break
            best = x
            if done or (detmin > 0 and abs(E_prev - E) <= POLISH_TOL * E):
                break
            sigma = max(1.0 - E / E_prev, SIGMA_MIN)
            mu = (1.0 - sigma) * float(_chi(np.array(detmin), eps))
            eps = max(2.0 * np.sqrt(mu * (mu - detmin)), 1e-10) if detmin < mu else 1e-10
            if not np.isfinite(eps):
                break
    out[move] = best.reshape(-1, 2)
    return out


def _newton_round(en: _Energy, solver: _Solver, x, eps, steps, budget: Budget):
    """Up to ``steps`` projected Newton steps with Armijo backtracking at fixed ``eps``.

    Returns ``x, E0, E, detmin, stopped``: the energies at the start and at ``x``, the
    smallest Jacobian determinant at ``x``, and whether the budget ended the round."""
    if not budget.affords(en.eval_cost):
        return x, np.inf, np.inf, -np.inf, True
    budget.charge(en.eval_cost)
    E0, dmin = en.energy(x, eps)
    E = E0
    for _ in range(steps):
        if not budget.affords(en.newton_cost + en.eval_cost):
            return x, E0, E, dmin, True
        budget.charge(en.newton_cost)
        E, g, data = en.newton(x, eps)
        if not (np.isfinite(g).all() and np.isfinite(data).all()):
            break
        p = -solver.solve(data, g)
        if not np.isfinite(p).all():
            break
        p /= max(np.abs(p).max() / en.step, 1.0)
        dec = -float(g @ p)
        if not dec > 1e-12 * E:
            break
        t = 1.0
        while t > 1e-8:
            if not budget.affords(en.eval_cost):
                return x, E0, E, dmin, True
            budget.charge(en.eval_cost)
            E_new, dmin_new = en.energy(x + t * p, eps)
            if E_new <= E - 1e-4 * t * dec:
                break
            t *= 0.5
        else:
            break
        x = x + t * p
        converged = E - E_new <= 1e-9 * E
        E, dmin = E_new, dmin_new
        if converged:
            break
    return x, E0, E, dmin, False
