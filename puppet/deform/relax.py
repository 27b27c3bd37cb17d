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
2. **Untangling** of what is still folded (:mod:`puppet.deform.untangle`): the free
   vertices of a region around the folds (3, 6, 12 rings with the outer ring fixed, then
   the whole mesh; mesh-boundary vertices inside a region are free, pins and pinless
   components fixed) minimise the foldover-free energy of Garanzha et al. (SIGGRAPH
   2021) by projected Newton steps on the region's own system (the ARAP matrix is never
   refactorised).

Both stages keep every pin exactly on its target and never move a component without
a pin. If a fold cannot be removed (e.g. three pins of one triangle given reversed
targets), the result with the fewest folds is returned, never more than given.

**Bounded work.** A relaxation spends at most ``budget`` work units
(:mod:`puppet.deform.budget`; one unit = one ARAP iteration of the mesh, a plain solve
is 20): every similarity iteration, fold check, Newton step and line-search energy is
charged by the size it works on (only the fold checks of the given pose are free), and
a stage that cannot be paid for is cut short or skipped. The result is the one with the fewest folds found within the budget (ties:
the earliest), so the same pins always give the same shape; the CPU-time cap of
:class:`~puppet.deform.budget.Budget` only backs this up. Far drags (pins moved several
times the layer's size) that tangle most of a mesh come out with fewer folds in bounded
time instead of minutes (``benchmarks/bench_fardrag.py``).
"""
from __future__ import annotations


import numpy as np
import scipy.sparse as sp

from puppet.deform import budget as cost
from puppet.deform.arap import ArapData
from puppet.deform.budget import Budget
from puppet.deform.factor import pair_solver as _pair_solver
from puppet.deform.threads import blas_capped
from puppet.deform.untangle import untangle

__all__ = ["folded_triangles", "relax_foldovers", "untangle", "default_budget", "BUDGET"]

#: Rings of the local untangling regions, tried in turn before the whole mesh.
UNTANGLE_RINGS = (3, 6, 12)
#: Rounds given to a local region before the next, larger one (its fixed outer ring
#: may leave no fold-free solution).
LOCAL_ROUNDS = 6
#: Default work budget of a relaxation, in work units (:mod:`puppet.deform.budget`: one
#: unit = one ARAP iteration of the mesh): 7 plain 20-iteration solves. The far-drag
#: benchmark keeps a relaxed pose within 10x the time of the plain one with it.
BUDGET = 140.0
#: Meshes with fewer vertices than this get ``BUDGET * FLOOR_VERTICES / n`` units: the
#: work of ``BUDGET`` iterations on a mesh of this size (a few tens of milliseconds), as
#: their own iterations cost next to nothing and their regions are most of the mesh.
FLOOR_VERTICES = 5000


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


def default_budget(n: int) -> float:
    """Work units of a relaxation on an ``n``-vertex mesh: ``BUDGET``, raised below
    ``FLOOR_VERTICES`` vertices to the work of ``BUDGET`` iterations at that size."""
    return BUDGET * max(1.0, FLOOR_VERTICES / max(int(n), 1))


@blas_capped
def relax_foldovers(data: ArapData, U, bc, *, rings: int = 1, s_min: float = 0.5, s_max: float = 1.5,
                    iterations: int = 20, rounds: int = 3, untangle_folds: bool = True,
                    budget: float | None = None, time_limit: float | None = None,
                    info: dict | None = None) -> np.ndarray:
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
        Similarity rounds while folds remain (0: untangle straight away). The untangling
        starts from the ARAP result, not from theirs. 3: more rounds (8+ rings,
        ``s_min`` <= 1/8) rarely remove the last folds and drift the region.
    untangle_folds : bool
        Run the untangling stage (:func:`untangle`) on folds the similarity rounds leave.
    budget : float, optional
        Work units the relaxation may spend (module docstring; one unit = one ARAP
        iteration of this mesh); ``inf``: unbounded. Default :func:`default_budget`:
        ``BUDGET`` = 140 units (seven plain 20-iteration solves) from
        ``FLOOR_VERTICES`` = 5000 vertices on, the work of 140 iterations on a
        5000-vertex mesh below.
    time_limit : float, optional
        CPU-time cap in seconds (this thread); default ``budget.TIME_CAP`` times the expected time
        of the budget (measured on the first fold check). Only a safety net: the budget
        ends the work first unless the machine gets much busier meanwhile.
    info : dict, optional
        Filled with ``"folds_in"``, ``"folds_out"``, ``"units"`` (spent), ``"budget"``,
        ``"late"`` (the time cap was reached) and ``"stage"`` (``"none"``,
        ``"similarity"``, ``"untangle"`` or ``"given"``: where the result comes from).

    Returns
    -------
    U : (n, 2) float
        ``U`` itself (the same array, untouched) when nothing is folded, which costs one
        vectorised sign check; otherwise a new finite array with pins exactly on ``bc``,
        pinless components at rest and no more folds than ``U`` had.
    """
    U = np.asarray(U, dtype=np.float64)
    V, F = data.V, data.F
    bad = folded_triangles(V, U, F)
    if info is not None:
        info.update(folds_in=len(bad), folds_out=len(bad), units=0.0, late=False, stage="none",
                    budget=float(default_budget(data.n) if budget is None else budget))
    if len(bad) == 0 and np.isfinite(U).all():
        return U
    bc = np.asarray(bc, dtype=np.float64).reshape(-1, 2)
    meter = Budget(default_budget(data.n) if budget is None else budget, time_limit)
    best = U.copy()
    lost = ~np.isfinite(best).all(axis=1)
    best[lost] = V[lost]  # never hand on a non-finite vertex
    best[data.b] = bc
    best[data.held] = V[data.held]
    t0 = cost.clock()
    bad = folded_triangles(V, best, F)  # of the given pose, pins on bc: not charged
    meter.calibrate((cost.clock() - t0) / cost.CHECK)
    start, stage = best, "given"
    # stage 1 makes the cells around the folds similarities and every other cell rigid: only
    # for rigid ARAP (a mesh solved in another mode goes straight to the untangling)
    if data.factor is not None and rounds > 0 and len(bad) and getattr(data, "mix", None) is None:
        X, left = _similarity_rounds(data, best, bc, bad, rings, s_min, s_max, iterations, rounds, meter)
        if len(left) < len(bad):
            best, bad, stage = X, left, "similarity"
    if untangle_folds and len(bad) and meter.affords(cost.REGION):
        tried = []
        meter.charge(cost.REGION)
        hops = _hops(data, folded_triangles(V, start, F), max(UNTANGLE_RINGS, default=0))
        for k in UNTANGLE_RINGS + (None,):
            if not meter.affords(cost.REGION + cost.CHECK):
                break
            meter.charge(cost.REGION)
            move = _untangle_region(data, hops, k)
            if not move.any() or any(np.array_equal(move, m) for m in tried):
                continue
            tried.append(move)
            if not meter.affords(cost.CHECK):
                break
            meter.charge(cost.CHECK)  # the fold check of its result, paid in advance
            X = untangle(V, F, start, np.flatnonzero(move),
                         max_rounds=60 if k is None else LOCAL_ROUNDS, budget=meter)
            left = folded_triangles(V, X, F)
            if len(left) < len(bad):
                best, bad, stage = X, left, "untangle"
            if len(bad) == 0:
                break
    if info is not None:
        info.update(folds_out=len(bad), units=meter.used, late=meter.late, stage=stage)
    return best


def _similarity_rounds(data: ArapData, U, bc, bad, rings, s_min, s_max, iterations, rounds,
                       meter: Budget):
    """Stage 1: local/global rounds with bounded-scale similarity cells around the folds.

    Each iteration is charged one unit and each fold check ``CHECK``; the rounds stop
    where ``meter`` ends. Returns the last result and its folded triangles."""
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
            if not meter.affords(1.0 + cost.CHECK):
                break
            cells = np.flatnonzero(region)
            S_c, q0_c, rest_c = data.S_f[cells], q0[cells], rest[cells]
            for _ in range(iterations):
                if not meter.affords(1.0 + cost.CHECK):
                    break
                meter.charge(1.0)
                qc = S_c @ xf + q0_c
                rc = np.abs(qc)
                rc[rc == 0] = 1.0
                sigma[cells] = qc / rc * np.clip(rc / rest_c, lo, s_max)
                x_new = solve(data.R @ (sigma - 1.0) - rb)
                if not np.isfinite(x_new).all():
                    break
                xf = x_new
            X = U.copy()
            X[free, 0], X[free, 1] = V[free, 0] + xf.real, V[free, 1] + xf.imag
            meter.charge(cost.CHECK)
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


def _hops(data: ArapData, bad, limit: int) -> np.ndarray:
    """Rings (edge hops) from the folded triangles' vertices, ``inf`` beyond ``limit``."""
    from scipy.sparse import csgraph  # lazy: csgraph loads scipy.linalg, 0.1 s of each start

    W = data.W
    G = sp.csr_matrix((np.ones(len(W.indices)), W.indices, W.indptr), shape=W.shape)
    seed = np.unique(data.F[bad])
    if len(seed) == 0:
        return np.full(data.n, np.inf)
    return csgraph.dijkstra(G, indices=seed, min_only=True, unweighted=True, limit=limit + 0.5)


def _untangle_region(data: ArapData, hops, rings) -> np.ndarray:
    """Vertices the untangling may move: ``rings`` rings around the folded triangles
    (``hops`` from :func:`_hops`) minus the outermost ring (fixed), or everything for
    ``rings=None``; never pins or pinless components. (n,) bool."""
    F = data.F
    if rings is None:
        move = np.ones(data.n, bool)
    else:
        region = hops <= rings
        move = region.copy()
        move[F[~region[F].all(axis=1)].ravel()] = False
    move[data.b] = False
    move[data.held] = False
    return move
