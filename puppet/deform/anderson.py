"""ARAP's local/global iteration with Anderson acceleration (Peng, Deng, Zhang, Yang,
Bouaziz and Liu, "Anderson Acceleration for Geometry Optimization and Physics
Simulation", SIGGRAPH 2018), run to a tolerance instead of a fixed count.

The plain iteration of :func:`puppet.deform.arap.arap_solve` is a fixed-point map
``x -> G(x)`` on the free displacements (local step: best rotations of ``x``; global
step: one solve with the reused factor). Anderson acceleration (type II, window ``m``)
takes, instead of ``G(x_k)``, the combination of the last ``m + 1`` values of ``G``
whose residuals ``f = G(x) - x`` combine to the least-squares smallest residual::

    x_{k+1} = G(x_k) - dG theta,   theta = argmin |f_k - dF theta|

(``dF``, ``dG``: differences of consecutive residuals and values of ``G``). It is
safeguarded by the energy, as the paper does: the local step of every iterate gives its
ARAP energy with the optimal rotations, and an accelerated iterate whose energy is not
below the last accepted one is replaced by the plain ``G`` of that one (whose energy
cannot be higher) and the history is dropped. So the energies of the accepted iterates
never increase, and the cost of an iteration stays one local step and one solve per
coordinate (plus a rejected step's extra local step).

The loop stops when no free vertex moves more than ``tolerance`` pixels in one plain
step (``max |G(x) - x|``), or after ``iterations`` solves. Energy, with displacements
``x = u - v`` and ``q_i = S0_i + (S x)_i`` (see :mod:`puppet.deform.arap`)::

    E(x) = sum_i k_i sum_j w_ij |u_ij - rho_i e_ij|^2
         = 2 sum_i k_i (Re q_i - |q_i|) + 2 x^H L x

(``rho_i = q_i / |q_i|``; ``L`` carries the cell weights ``k``), which is
:func:`puppet.deform.arap.arap_energy` for ``k = 1``; both terms vanish at rest, so it
is free of the cancellation of the textbook form. Only the rigid loop is accelerated
(no ``data.mix``: the modes have other local steps).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from puppet.deform import factor
from puppet.deform.arap import ArapData, _check_bc, _rotation_minus_one, initial_positions
from puppet.deform.threads import one_blas_thread

__all__ = ["AndersonInfo", "arap_solve_anderson", "WINDOW", "TOLERANCE"]

#: Residuals kept (Peng et al. use 5-6 for local/global solvers).
WINDOW = 5
#: Default tolerance: the largest step of a vertex in one plain iteration, px.
TOLERANCE = 0.01


@dataclass
class AndersonInfo:
    """What :func:`arap_solve_anderson` did."""

    iterations: int = 0  # global solves (one per coordinate each)
    converged: bool = False  # the tolerance was reached within the iterations
    rejected: int = 0  # accelerated iterates refused by the energy check
    energies: list[float] = field(default_factory=list)  # accepted iterates', non-increasing
    steps: list[float] = field(default_factory=list)  # max |G(x) - x| of each, px


def arap_solve_anderson(data: ArapData, bc, *, iterations: int = 20, tolerance: float = TOLERANCE,
                        U0=None, window: int = WINDOW) -> tuple[np.ndarray, AndersonInfo]:
    """Rigid ARAP with Anderson acceleration, to a tolerance.

    Parameters
    ----------
    data : ArapData
        From :func:`puppet.deform.arap.arap_precompute` without ``mix``; never refactorised.
    bc : (k, 2) float
        Targets of the pinned vertices ``data.b``.
    iterations : int
        Most global solves.
    tolerance : float
        Stop when no vertex moves more than this in a plain iteration, px (> 0).
    U0 : (n, 2) float, optional
        Initial guess; None: the MLS guess of :func:`~puppet.deform.arap.arap_solve`.
    window : int
        Anderson window ``m`` (0: the plain iteration, with the stopping test).

    Returns
    -------
    U : (n, 2) float
        The plain ``G`` of the last accepted iterate (so its energy is at most the
        last one reported); ``U[b] == bc``, held components at rest, always finite.
    info : AndersonInfo
    """
    if data.mix is not None:
        raise ValueError("Anderson acceleration is for the rigid loop (data.mix must be None)")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0, got {tolerance}")
    with one_blas_thread():
        bc = _check_bc(data, bc)
        U = initial_positions(data, bc, U0)
        info = AndersonInfo()
        if data.factor is None or int(iterations) <= 0:
            return U, info
        V, free, b = data.V, data.free, data.b
        xf = (U[free, 0] - V[free, 0]) + 1j * (U[free, 1] - V[free, 1])
        xb = (bc[:, 0] - V[b, 0]) + 1j * (bc[:, 1] - V[b, 1])
        xf = _iterate(data, xb, xf, int(iterations), float(tolerance), int(window), info)
        U[free, 0], U[free, 1] = V[free, 0] + xf.real, V[free, 1] + xf.imag
        return U, info


def _local_step(data: ArapData, xb: np.ndarray):
    """``step(xf) -> (rhs, energy)``: the global step's right-hand side for the best
    rotations of ``xf`` (pins at ``xb``) and the energy of ``xf`` with them."""
    q0 = data.S0 + data.S_b @ xb
    rb = data.L_fb @ xb
    sigma = np.empty(data.n, dtype=np.complex128)
    x = np.zeros(data.n, dtype=np.complex128)
    x[data.b] = xb

    def step(xf):
        q = data.S_f @ xf
        q += q0
        cells = q.real - np.abs(q)
        rhs = data.R @ _rotation_minus_one(q, sigma)
        rhs -= rb
        x[data.free] = xf
        energy = 2.0 * (cells.sum() if data.k is None else data.k @ cells) + 2.0 * np.vdot(x, data.L @ x).real
        return rhs, float(energy)
    return step


def _iterate(data, xb, xf, iterations, tolerance, window, info) -> np.ndarray:
    """The safeguarded Anderson loop over the free displacements; returns the result."""
    step = _local_step(data, xb)
    solve, close = factor.pair_solver(data.factor, len(data.free), iterations)
    dF, dG = [], []
    f_prev = g_prev = g_last = None
    try:
        rhs, energy = step(xf)
        for _ in range(iterations):
            if info.energies and not energy < info.energies[-1]:  # worse (or NaN): the plain step
                info.rejected += 1
                xf, dF, dG, f_prev = g_last, [], [], None
                rhs, energy = step(xf)
                if not energy <= info.energies[-1]:  # no plain progress either (rounding): done
                    break
            info.energies.append(energy)
            g = solve(rhs)
            info.iterations += 1
            if not np.isfinite(g).all():  # a breakdown: keep the last finite iterate
                return xf if g_last is None else g_last
            f = g - xf
            info.steps.append(float(np.abs(f).max(initial=0.0)))
            g_last = g
            if info.steps[-1] <= tolerance:
                info.converged = True
                break
            if f_prev is not None and window > 0:
                dF.append(f - f_prev)
                dG.append(g - g_prev)
                del dF[:-window], dG[:-window]
            f_prev, g_prev = f, g
            xf = g - _combination(dF, dG, f) if dF else g
            rhs, energy = step(xf)
    finally:
        close()
    return g_last


def _combination(dF: list, dG: list, f: np.ndarray) -> np.ndarray:
    """``dG theta`` with ``theta = argmin |f - dF theta|`` (normal equations, a tiny ridge
    against collinear columns; complex vectors read as real ones)."""
    A = np.stack([d.view(np.float64) for d in dF], axis=1)
    gram = A.T @ A
    gram[np.diag_indices_from(gram)] += 1e-12 * max(np.trace(gram), 1e-300)
    theta = np.linalg.solve(gram, A.T @ f.view(np.float64))
    return np.stack(dG, axis=1) @ theta
