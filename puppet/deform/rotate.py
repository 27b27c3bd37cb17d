"""Pins with an angle: the region around a pin turns about it (rotation about pins).

A pose gives every pin ``b[i]`` a target ``bc[i]`` and an angle ``theta_i`` in degrees,
counter-clockwise *as seen on screen*. Canvas coordinates have y pointing down, so in
raw ``(x, y)`` coordinates that is the matrix of the angle ``phi_i = -theta_i``::

    R(theta) = [[cos theta,  sin theta],      e.g. theta = 90: (1, 0) -> (0, -1),
                [-sin theta, cos theta]]      a point right of the pin moves up.

Algorithm (rotation about pins, after the garment-retargeting paper, s.3.1.3):

1. Initial guess (:func:`rotation_initial_guess`): each vertex follows its nearest
   pin by geodesic distance (``data.D``): ``u = bc_i + R(theta_i) (v - V[b_i])``, a
   rigid turn about the pin plus the pin's translation. Vertices whose nearest pin has
   ``theta = 0`` take the ordinary object-space rigid MLS guess of :func:`arap_solve`.
2. Held rotation: cells (per-vertex ARAP cells) whose nearest pin ``i`` has
   ``theta_i != 0`` and that lie within ``hold * d_i`` of it (``d_i`` the geodesic
   distance from pin ``i`` to the nearest other pin, infinite when it is alone) keep
   ``R_i = R(theta_i)`` in every local step instead of their best-fit rotation, so
   ARAP cannot turn the region back. A fixed rotation only changes the right-hand
   side, never the matrix.
3. ARAP pass over all free vertices, from the guess, with the held rotations: the
   precomputed factor of ``data`` is reused (no factorisation).
4. ``rounds`` residual rounds: the per-cell energy (eq. 4 of the paper)
   ``r_i = sum_j w_ij |(u_i - u_j) - R_i (v_i - v_j)|^2`` (held ``R_i`` where held,
   best fit elsewhere) is evaluated; the cells with ``r_i > eps``, grown by one ring,
   are re-solved with ``iterations`` local/global steps while every other vertex is
   held as a constraint at its current position. That free set is small, so its
   block of the Laplacian is factorised afresh each round (cost reported in
   ``info``); a round whose set is empty ends the loop.

Step 3 is not in the paper, whose ARAP is only the residual rounds of step 4. Measured
with the energy of the held problem (600-vertex body + neck + head, head turned -30
degrees about a neck pin, converged energy 15.0): rounds alone (3 rounds) leave 31.9,
since the seam between the turned region and the MLS guess is relaxed only inside
the hot band; the full pass gives 16.4 without any factorisation, and 3 rounds after
it 15.9. On the 5k-vertex puppet of ``benchmarks/bench_rotate.py`` the rounds after
the pass change the energy by < 0.1 % (132.79 -> 132.78, converged 129.64) for about
twice the time, while 20 more iterations of the pass reach 129.97: the remaining
error is smooth and global, which a local re-solve with fixed surroundings cannot
remove. ``rounds=0`` is the cheap setting.

With every angle 0 nothing of this happens: :func:`arap_solve` is called as is.
"""
from __future__ import annotations

import time

import numpy as np

from puppet.deform.arap import ArapData, _check_bc, arap_solve
from puppet.deform.factor import factorize as _factorize
from puppet.deform.mls import mls_object_space
from puppet.deform.threads import blas_capped

__all__ = ["screen_rotation", "rotation_initial_guess", "held_rotations", "cell_residuals",
           "default_eps", "arap_solve_rotated", "mode_solve_rotated"]

#: Default ``eps``: this many times the median cell residual after the full pass ...
EPS_MEDIAN = 10.0
#: ... but at least this times the median rest spoke energy ``sum_j w_ij |e_ij|^2``.
EPS_REL = 1e-4


def screen_rotation(angles_deg) -> np.ndarray:
    """Raw-coordinate rotation matrices of on-screen counter-clockwise angles (y down).

    Parameters
    ----------
    angles_deg : (k,) float
        Degrees, counter-clockwise as seen on screen.

    Returns
    -------
    R : (k, 2, 2) float
        ``[[cos, sin], [-sin, cos]]``: apply as ``R @ (x, y)``.
    """
    t = np.deg2rad(np.asarray(angles_deg, dtype=np.float64).reshape(-1))
    c, s = np.cos(t), np.sin(t)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], -2)


def _check_angles(data: ArapData, angles_deg) -> np.ndarray:
    a = np.asarray(angles_deg, dtype=np.float64)
    if a.size == 0 and len(data.b) == 0:
        return np.zeros(0)
    if a.shape != (len(data.b),):
        raise ValueError(f"angles_deg must have shape (k,) = ({len(data.b)},), got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError("angles_deg must be finite")
    return a


def _nearest_pin(data: ArapData) -> np.ndarray:
    """(n,) index into ``data.b`` of each vertex's geodesically nearest pin, -1 if none."""
    if len(data.b) == 0:
        return np.full(data.n, -1, dtype=np.int64)
    near = data.D.argmin(axis=0)
    return np.where(np.isfinite(data.D.min(axis=0)), near, -1)


@blas_capped
def rotation_initial_guess(data: ArapData, bc, angles_deg) -> np.ndarray:
    """Initial guess with every vertex turned about its nearest pin by that pin's angle.

    Parameters
    ----------
    data : ArapData
        From :func:`puppet.deform.arap.arap_precompute` (uses ``V, b, D, alpha``).
    bc : (k, 2) float
        Pin targets.
    angles_deg : (k,) float
        Pin angles, degrees counter-clockwise on screen (y down).

    Returns
    -------
    U0 : (n, 2) float
        ``bc_i + R(theta_i) (V - V[b_i])`` for the vertices whose nearest pin ``i``
        (by ``data.D``) has ``theta_i != 0``; the object-space rigid MLS guess of
        :func:`arap_solve` for the others (so all angles 0 give exactly that guess);
        vertices no pin reaches stay at rest; ``U0[b] == bc``.
    """
    bc = _check_bc(data, bc)
    angles = _check_angles(data, angles_deg)
    V, b = data.V, data.b
    U = mls_object_space(V, data.D, bc, V[b], kind="rigid", alpha=data.alpha, weights=data.mls_weights())
    near = _nearest_pin(data)
    turned = np.flatnonzero((near >= 0) & (angles[np.maximum(near, 0)] != 0))
    if len(turned):
        i = near[turned]
        R = screen_rotation(angles)[i]
        U[turned] = bc[i] + np.einsum("nab,nb->na", R, V[turned] - V[b[i]])
    U[b] = bc
    return U


def held_rotations(data: ArapData, angles_deg, *, hold: float = 0.5):
    """Cells whose rotation is held at their pin's angle during the ARAP local step.

    Parameters
    ----------
    data : ArapData
    angles_deg : (k,) float
        Pin angles, degrees counter-clockwise on screen.
    hold : float
        A cell is held when its nearest pin ``i`` has ``theta_i != 0`` and its geodesic
        distance to that pin is at most ``hold * d_i``, ``d_i`` the distance from pin
        ``i`` to the nearest other pin (infinite when no other pin reaches it). With
        ``hold = 0.5`` the held disc reaches the Voronoi border towards that pin.

    Returns
    -------
    cells : (h,) int
        Held cells (vertex indices).
    cm1, s : (h,) float
        ``cos(phi) - 1`` and ``sin(phi)`` of their raw-coordinate angle
        ``phi = -theta`` (the form :mod:`puppet.deform.arap` stacks rotations in).
    """
    angles = _check_angles(data, angles_deg)
    if not hold >= 0:
        raise ValueError(f"hold must be >= 0, got {hold}")
    near = _nearest_pin(data)
    ok = near >= 0
    on = np.zeros(data.n, dtype=bool)
    on[ok] = angles[near[ok]] != 0
    if on.any():
        Db = data.D[:, data.b].copy()
        np.fill_diagonal(Db, np.inf)
        reach = hold * Db.min(axis=1)  # (k,), inf for a lone pin
        on[ok] &= data.D[near[ok], np.flatnonzero(ok)] <= reach[near[ok]]
    cells = np.flatnonzero(on)
    phi = -np.deg2rad(angles[near[cells]])
    # cos(phi) - 1 without cancellation
    return cells, -2.0 * np.sin(0.5 * phi) ** 2, np.sin(phi)


def _best_rotations(a: np.ndarray, s: np.ndarray):
    """(cos - 1, sin) of atan2(s, a), as ``puppet.deform.arap._rotations`` forms them."""
    r = np.hypot(a, s)
    ok = r > 0
    r = np.where(ok, r, 1.0)
    cm1 = np.where(a >= 0, -(s * s) / (r * (np.abs(a) + r)), a / r - 1.0)
    return np.where(ok, cm1, 0.0), np.where(ok, s / r, 0.0)


def _held_at(cells: np.ndarray, held):
    """Positions in ``cells`` (sorted) of the held cells they contain, and their
    (cos - 1, sin)."""
    hc, hcm1, hs = held
    at = np.searchsorted(cells, hc)
    hit = at < len(cells)
    hit[hit] = cells[at[hit]] == hc[hit]
    return at[hit], hcm1[hit], hs[hit]


def _cell_rotations(C_rows, U, m: int, held_at):
    """(cos - 1, sin) of ``m`` cells: best fit, overridden where held.

    ``C_rows`` holds the rows ``[cells, n + cells]`` of ``data.C``; ``held_at`` is
    :func:`_held_at` of those cells.
    """
    CU = C_rows @ U
    cm1, s = _best_rotations(CU[:m, 0] + CU[m:, 1], CU[:m, 1] - CU[m:, 0])
    at, hcm1, hs = held_at
    cm1[at] = hcm1
    s[at] = hs
    return cm1, s


def cell_residuals(data: ArapData, U, held=None) -> np.ndarray:
    """Per-cell ARAP energy ``sum_j w_ij |(u_i - u_j) - R_i (v_i - v_j)|^2``.

    Parameters
    ----------
    data : ArapData
    U : (n, 2) float
        Deformed positions.
    held : tuple, optional
        ``(cells, cm1, s)`` from :func:`held_rotations`: those cells use the held
        rotation, the others the best-fit one.

    Returns
    -------
    r : (n,) float
        Sums to :func:`puppet.deform.arap.arap_energy` when nothing is held. A cell
        with negative cotangent weights (obtuse boundary triangles) may get a
        slightly negative value.
    """
    U = np.asarray(U, dtype=np.float64)
    if held is None:
        held = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
    cm1, s = _cell_rotations(data.C, U, data.n, _held_at(np.arange(data.n), held))
    c, s = (cm1 + 1.0)[data.ei], s[data.ei]
    ex, ey = data.ev[:, 0], data.ev[:, 1]
    du = U[data.ei] - U[data.ej]
    rx = du[:, 0] - (c * ex - s * ey)
    ry = du[:, 1] - (s * ex + c * ey)
    return np.bincount(data.ei, weights=data.ew * (rx * rx + ry * ry), minlength=data.n)


def default_eps(data: ArapData, residuals: np.ndarray) -> float:
    """Residual threshold: ``max(EPS_MEDIAN * median(r), EPS_REL * median(spoke))``.

    ``r`` are the current cell residuals and ``spoke_i = sum_j w_ij |v_i - v_j|^2`` the
    rest spoke energies: a cell is "hot" when its energy is ten times that of a
    typical cell, and never for less than about 1 % strain of every spoke (so a
    nearly rigid pose does not chase round-off).
    """
    spoke = np.bincount(data.ei, weights=data.ew * (data.ev ** 2).sum(1), minlength=data.n)
    if data.n == 0:
        return 0.0
    return max(EPS_MEDIAN * float(np.median(residuals)),
               EPS_REL * float(np.median(np.abs(spoke))))


def _solve_region(data: ArapData, U, A, factor, held, iterations: int) -> None:
    """Local/global ARAP steps on the free vertices ``A`` (sorted subset of
    ``data.free``), every other vertex held at ``U``; ``factor`` factorises
    ``L[A][:, A]``. Updates ``U`` in place."""
    n, V = data.n, data.V
    if len(A) == len(data.free):  # the whole free set: the precomputed operators
        K_A, cells, C_rows = data.K, np.arange(n), data.C
    else:
        K_A = data.K[np.searchsorted(data.free, A)]
        cells = np.unique(K_A.indices % n)  # the cells whose rotation reaches these rows
        cols = np.concatenate([cells, n + cells])
        K_A = K_A[:, cols]
        C_rows = data.C[cols]
    held_at = _held_at(cells, held)
    X = U - V
    X[A] = 0.0
    rhs0 = data.L[A] @ X  # coupling to everything held, fixed during the region solve
    m = len(cells)
    Z = np.empty((2 * m, 2))
    VA = V[A]
    for _ in range(int(iterations)):
        cm1, s = _cell_rotations(C_rows, U, m, held_at)
        Z[:m, 0] = cm1
        Z[:m, 1] = s
        Z[m:, 0] = -s
        Z[m:, 1] = cm1
        U[A] = VA + factor.solve(K_A @ Z - rhs0)


def _grow(data: ArapData, mask: np.ndarray) -> np.ndarray:
    """Mask grown by one ring of mesh neighbours."""
    out = mask.copy()
    out[data.ej[mask[data.ei]]] = True
    return out


@blas_capped
def arap_solve_rotated(data: ArapData, bc, angles_deg, *, iterations: int = 20,
                       eps: float | None = None, rounds: int = 3, hold: float = 0.5,
                       info: dict | None = None) -> np.ndarray:
    """ARAP with pins that also turn the region around them by an angle.

    Parameters
    ----------
    data : ArapData
        From :func:`puppet.deform.arap.arap_precompute`; its factor is reused, never
        changed.
    bc : (k, 2) float
        Targets of the pins ``data.b``.
    angles_deg : (k,) float
        Angle of each pin, degrees counter-clockwise as seen on screen (y down);
        0 for a pin that only moves.
    iterations : int
        Local/global iterations of the full pass and of each residual round.
    eps : float, optional
        Residual threshold of a cell (energy units: px^2 for cotangent weights).
        Default (:func:`default_eps`, fixed after the full pass): 10 times the median
        cell residual, at least ``1e-4 *`` the median rest spoke energy
        ``sum_j w_ij |v_i - v_j|^2`` (about 1 % strain of every spoke).
    rounds : int
        Maximum number of residual rounds; each factorises the free block of its
        high-residual region once (reused when a round selects the same region);
        0 stops after the full pass.
    hold : float
        Radius of the held-rotation region, as a fraction of the geodesic distance
        from the turned pin to its nearest other pin (see :func:`held_rotations`).
    info : dict, optional
        Filled with ``"rounds"``: a list of ``{"cells", "free", "factor_s", "solve_s"}``
        per residual round (hot cells, free vertices of the re-solved block, seconds
        to factorise and to iterate), ``"held"``: the number of held cells, and
        ``"eps"``: the threshold used.

    Returns
    -------
    U : (n, 2) float
        Deformed positions; ``U[b] == bc`` exactly; components without pins at rest.
        All angles 0 return ``arap_solve(data, bc, iterations=iterations)`` itself.
    """
    bc = _check_bc(data, bc)
    angles = _check_angles(data, angles_deg)
    if info is not None:
        info.update(rounds=[], held=0, eps=None)
    if not angles.any():
        return arap_solve(data, bc, iterations=iterations)
    U = rotation_initial_guess(data, bc, angles)
    U[data.held] = data.V[data.held]
    if data.factor is None:
        return U
    held = held_rotations(data, angles, hold=hold)
    if info is not None:
        info["held"] = len(held[0])
    _solve_region(data, U, data.free, data.factor, held, iterations)
    is_free = np.zeros(data.n, dtype=bool)
    is_free[data.free] = True
    A_prev, factor = None, None
    for k in range(int(rounds)):
        r = cell_residuals(data, U, held)
        if k == 0:
            eps = default_eps(data, r) if eps is None else float(eps)
            if info is not None:
                info["eps"] = eps
        hot = r > eps
        A = np.flatnonzero(_grow(data, hot) & is_free)
        if len(A) == 0:
            break
        t0 = time.perf_counter()
        if len(A) == len(data.free):
            factor = data.factor
        elif A_prev is None or not np.array_equal(A, A_prev):  # else: same block, reuse
            factor = _factorize(data.L[A][:, A], data.factor.kind)
        A_prev = A
        t1 = time.perf_counter()
        _solve_region(data, U, A, factor, held, iterations)
        if info is not None:
            info["rounds"].append({"cells": int(hot.sum()), "free": len(A),
                                   "factor_s": t1 - t0, "solve_s": time.perf_counter() - t1})
    U[data.b] = bc
    return U


def mode_solve_rotated(data, bc, angles_deg, *, iterations: int = 20, scale=None) -> np.ndarray:
    """Pins that also turn the region around them, in a mode other than rigid.

    As :func:`arap_solve_rotated`'s full pass: every vertex whose nearest pin is turned
    starts turned about it, and the cells near a turned pin keep its rotation while the
    others take their mode's fit (no residual rounds: those re-solve rigid cells). Returns U (n, 2) with ``U[b] == bc``.
    """
    U0 = rotation_initial_guess(data, bc, angles_deg)
    cells, cm1, s = held_rotations(data, angles_deg)
    return arap_solve(data, bc, iterations=iterations, U0=U0, held=(cells, (cm1 + 1.0) + 1j * s), scale=scale)
