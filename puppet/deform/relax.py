"""Relaxed ARAP: remove fold-overs left by point-constrained ARAP (garment paper §3.1.2).

Point constraints dragged against the local rotation can leave a few triangles folded
(signed area flipped) at the converged ARAP minimum, typically around a pin at a thin
tip of the shape. Relaxed ARAP re-solves around them: the cells of the folded
triangles and a few rings of neighbours may use a **similarity** (rotation times a
scale ``s`` clamped to ``[s_min, s_max]``) instead of a pure rotation, so the region
can shrink or grow a little instead of folding. Only the right-hand side of the global
step changes, so the ARAP factorisation is reused (no refactorisation). If folds remain,
the region grows and ``s_min`` halves, for a few rounds; then the folded region is
untangled by neighbour averaging with its border fixed (Tutte), and as a last resort its
vertices are blended toward a fold-free initial guess.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from puppet.deform.arap import ArapData
from puppet.deform.factor import pair_solver as _pair_solver
from puppet.deform.mls import mls_object_space

__all__ = ["folded_triangles", "relax_foldovers"]


def _areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]


def folded_triangles(V_rest, U, F) -> np.ndarray:
    """Indices of triangles whose signed area changed sign (or vanished), (j,) int."""
    F = np.asarray(F)
    a0 = _areas(np.asarray(V_rest, float), F)
    a1 = _areas(np.asarray(U, float), F)
    return np.flatnonzero((a0 * a1 <= 0) & (a0 != 0))


def _grow(adj: sp.csr_matrix, mask: np.ndarray, rings: int) -> np.ndarray:
    for _ in range(rings):
        mask = mask | (adj @ mask.astype(np.float64) > 0)
    return mask


def relax_foldovers(data: ArapData, U, bc, *, rings: int = 1, s_min: float = 0.5, s_max: float = 1.5,
                    iterations: int = 20, rounds: int = 8) -> np.ndarray:
    """Re-solve the neighbourhood of folded triangles with bounded-scale similarity cells.

    Parameters
    ----------
    data : ArapData
        The group's ARAP precomputation (its factor is reused).
    U : (n, 2) float
        An ARAP result for the targets ``bc``.
    bc : (k, 2) float
        Targets of the pinned vertices ``data.b``.
    rings : int
        Rings of neighbours added around the folded triangles' vertices in the first
        round (1, measured best on the test drags and the bundled scenes: wider first
        regions let cells near a pin shrink and fold elsewhere).
    s_min, s_max : float
        Bounds of the similarity scale of relaxed cells (first round; ``s_min`` halves
        every further round).
    iterations : int
        Local/global iterations per round.
    rounds : int
        Rounds while folds remain; each adds the new folds' vertices, grows the region
        by twice as many rings as the round before and halves ``s_min``.

    Returns
    -------
    U : (n, 2) float
        ``U`` itself (the same array) when nothing is folded; otherwise the relaxed
        result, pins exactly on ``bc``.
    """
    U = np.asarray(U, dtype=np.float64)
    F, V = data.F, data.V
    bad = folded_triangles(V, U, F)
    if len(bad) == 0 or data.factor is None:
        return U
    bc = np.asarray(bc, dtype=np.float64).reshape(-1, 2)
    n = data.n
    adj = (data.W != 0).astype(np.float64).tocsr()
    region = np.zeros(n, bool)
    region[F[bad].ravel()] = True
    region = _grow(adj, region, rings)
    free, b = data.free, data.b
    nf = len(free)
    xb = (bc[:, 0] - V[b, 0]) + 1j * (bc[:, 1] - V[b, 1])
    q0 = data.S0 + data.S_b @ xb
    rb = data.L_fb @ xb
    rest_scale = np.where(data.S0 > 0, data.S0, 1.0)
    U0 = U
    U = U.copy()
    lo = s_min
    solve, close = _pair_solver(data.factor, nf, iterations * rounds)
    try:
        for _ in range(rounds):
            xf = (U[free, 0] - V[free, 0]) + 1j * (U[free, 1] - V[free, 1])
            for _ in range(iterations):
                q = data.S_f @ xf
                q += q0
                r = np.abs(q)
                r[r == 0] = 1.0
                s = np.where(region, np.clip(r / rest_scale, lo, s_max), 1.0)
                rhs = data.R @ (s * q / r - 1.0)
                rhs -= rb
                xf = solve(rhs)
            U[free, 0], U[free, 1] = V[free, 0] + xf.real, V[free, 1] + xf.imag
            bad = folded_triangles(V, U, F)
            if len(bad) == 0:
                return U
            grow = np.zeros(n, bool)
            grow[F[bad].ravel()] = True
            region = _grow(adj, region | grow, rings)
            rings *= 2
            lo *= 0.5
    finally:
        close()
    candidates = [U0, U]
    U = _untangle(data, U, adj)
    if len(folded_triangles(V, U, F)) == 0:
        return U
    candidates += [U, _blend_toward_guess(data, U, bc, adj)]
    # never hand back more folds than we were given
    return min(candidates, key=lambda X: len(folded_triangles(V, X, F)))


def _untangle(data: ArapData, U, adj, sweeps: int = 200) -> np.ndarray:
    """Tutte-style untangling: the free vertices of the folded triangles and two rings
    around them move to the average of their neighbours (Jacobi sweeps), everything
    else fixed. Fold-free when the fixed border of the region is convex; used only
    when the similarity rounds left folds."""
    V, F = data.V, data.F
    n = data.n
    move = np.zeros(n, bool)
    move[F[folded_triangles(V, U, F)].ravel()] = True
    move = _grow(adj, move, 2)
    move[data.b] = False
    move[data.held] = False
    deg = np.asarray(adj.sum(axis=1)).ravel()
    deg[deg == 0] = 1.0
    U = U.copy()
    for k in range(sweeps):
        avg = (adj @ U) / deg[:, None]
        U[move] = avg[move]
        if k % 20 == 19 and len(folded_triangles(V, U, F)) == 0:
            break
    return U


def _blend_toward_guess(data: ArapData, U, bc, adj) -> np.ndarray:
    """Last resort: move the free vertices of the remaining folded triangles, with the
    smallest neighbourhood that works, toward a fold-free guess until no fold remains.

    The MLS guess is tried with neighbourhoods of 2 to 128 rings; the rest mesh (pins
    moved) only locally, up to 8 rings, since blending a large region toward rest would
    undo the pose."""
    V, F = data.V, data.F
    mls = mls_object_space(V, data.D, bc, V[data.b], kind="rigid", alpha=data.alpha)
    mls[data.held] = V[data.held]
    mls[data.b] = bc
    rest = V.copy()
    rest[data.b] = bc
    guesses = [(rest, (2, 4, 8))]
    if len(folded_triangles(V, mls, F)) == 0:
        guesses.insert(0, (mls, (2, 4, 8, 16, 32, 64, 128)))
    seed = np.zeros(data.n, bool)
    seed[F[folded_triangles(V, U, F)].ravel()] = True
    best, fewest = U, len(folded_triangles(V, U, F))
    for G, ring_list in guesses:
        for rings in ring_list:
            move = _grow(adj, seed, rings)
            move[data.b] = False
            for t in np.linspace(0.1, 1.0, 10):
                W = U.copy()
                W[move] = (1 - t) * U[move] + t * G[move]
                k = len(folded_triangles(V, W, F))
                if k == 0:
                    return W
                if k < fewest:
                    best, fewest = W, k
    return best
