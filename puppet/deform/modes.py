"""Deformation modes of the ARAP solver: what each cell may do besides turning.

Every cell ``i`` (a vertex and its spokes ``e_ij = v_i - v_j``) fits a 2D linear map
``T_i`` to its deformed spokes ``u_ij``; the global step then places the vertices so that
``u_ij`` matches ``(T_i + T_j) e_ij / 2`` in the least-squares sense. The mode says which
maps are allowed:

``rigid``
    rotations (Sorkine & Alexa 2007): the fit is ``q_i / |q_i|`` with
    ``q_i = sum_j w_ij conj(e_ij) u_ij`` (points as complex numbers).
``similar``
    similarities, rotation times a uniform scale ("as similar as possible"; Igarashi,
    Moscovich & Hughes 2005 step 1; Liu et al. 2008 call it ASAP): the least-squares
    similarity of the cell is ``a_i = q_i / sum_j w_ij |e_ij|^2``, so a part may grow or
    shrink evenly without folding. With ``scale=(lo, hi)`` its modulus is clipped to
    [lo, hi] (the exact fit over those similarities): unbounded similarity cells make a
    discrete conformal map, which pinches near point handles and balloons between them.
``distort``
    half rigid, half affine: the energy is ``(E_rigid + E_affine) / 2``. The affine fit
    ``u = a e + b conj(e)`` solves the 2x2 complex normal equations
    ``[S0, conj(G); G, S0] [a; b] = [q; p]`` with ``p_i = sum_j w_ij e_ij u_ij`` and
    ``G_i = sum_j w_ij e_ij^2`` (a pure affine energy alone has a whole family of
    zero-energy solutions for two pins, some collapsed to a line; the rigid half keeps
    the cells from degenerating).

A cell may also mix modes: ``mix`` (n, 3) gives the weights of the rigid, similar and
affine energies of each cell (rows summing to 1). The energy stays a sum of convex
quadratics in (U, T) for fixed rotations, so the alternating local/global iterations
decrease it monotonically; all three share the Laplacian, so no mode refactorises.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["MODES", "MIX", "mode_mix", "cell_sigma", "similarity_fit", "apply_similarity",
           "stiffness_from_grey", "STIFF_MAX", "ModeOps", "mode_operators", "mode_rhs", "SCALE_SPAN"]

#: The modes and the (rigid, similar, affine) weights of their cell energies.
MIX = {"rigid": (1.0, 0.0, 0.0), "similar": (0.0, 1.0, 0.0), "distort": (0.5, 0.0, 0.5)}
MODES = tuple(MIX)

#: In a scene, the scale of a ``similar`` cell stays within this factor of the scale of
#: the pins' least-squares similarity (``puppet.scene.rig.solve.scale_bounds``).
SCALE_SPAN = 1.25

#: Cell weight of the stiffest paint (grey 255); grey 0 weighs 1.
STIFF_MAX = 100.0


def mode_mix(modes, stiff=None) -> np.ndarray:
    """Per-cell (rigid, similar, affine) weights.

    Parameters
    ----------
    modes : sequence of str, length n
        The mode of each cell (one of :data:`MODES`).
    stiff : (n,) float in [0, 1], optional
        Painted stiffness (grey / 255): a cell of stiffness t keeps the fraction t of its
        energy rigid, whatever the mode.

    Returns
    -------
    mix : (n, 3) float
        Rows sum to 1.
    """
    table = np.array([MIX[m] for m in MODES])
    idx = np.array([MODES.index(m) for m in modes], dtype=np.int64)
    mix = table[idx] if len(idx) else np.zeros((0, 3))
    if stiff is not None:
        t = np.clip(np.asarray(stiff, np.float64), 0.0, 1.0)[:, None]
        mix = (1.0 - t) * mix + t * table[0]
    return mix


def stiffness_from_grey(grey) -> np.ndarray:
    """Cell weights from painted grey levels: ``k = STIFF_MAX ** (g / 255)``.

    0 (unpainted) weighs 1, 128 about 10, 255 weighs :data:`STIFF_MAX` (100): each 55
    grey levels multiply the weight by about 2.7, so the brush acts evenly over its range.
    """
    g = np.clip(np.asarray(grey, np.float64), 0.0, 255.0)
    return STIFF_MAX ** (g / 255.0)


def cell_sigma(mix: np.ndarray, q: np.ndarray, p: np.ndarray | None, S0: np.ndarray,
               G: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Blended cell maps, as ``(sigma, beta)``: ``T_i e = (1 + sigma_i) e + beta_i conj(e)``.

    Parameters
    ----------
    mix : (n, 3) float
        Rigid, similar and affine weights per cell.
    q : (n,) complex
        ``sum_j w_ij conj(e_ij) u_ij``.
    p : (n,) complex or None
        ``sum_j w_ij e_ij u_ij`` (only needed when some cell has an affine part).
    S0 : (n,) float
        ``sum_j w_ij |e_ij|^2``.
    G : (n,) complex or None
        ``sum_j w_ij e_ij^2``.

    Returns
    -------
    sigma : (n,) complex
    beta : (n,) complex or None (no affine part anywhere)
    """
    r = np.abs(q)
    r[r == 0] = 1.0
    rest = np.where(S0 > 0, S0, 1.0)
    sigma = mix[:, 0] * (q / r - 1.0) + mix[:, 1] * (q / rest - 1.0)
    if p is None or G is None or not mix[:, 2].any():
        return sigma, None
    det = S0 * S0 - (G * G.conj()).real
    ok = det > 1e-12 * np.maximum(S0 * S0, 1e-300)  # collinear spokes: no affine fit
    det = np.where(ok, det, 1.0)
    a = np.where(ok, (S0 * q - G.conj() * p) / det, q / r)
    b = np.where(ok, (S0 * p - G * q) / det, 0.0)
    sigma += mix[:, 2] * (a - 1.0)
    return sigma, mix[:, 2] * b


def similarity_fit(P, Q) -> tuple[complex, complex]:
    """Least-squares similarity (rotation, uniform scale, shift; no reflection) taking
    points ``P`` (k, 2) to ``Q`` (k, 2): ``z -> s z + t`` in complex numbers.

    One point gives the shift alone (s = 1); coincident points likewise.
    """
    P = np.asarray(P, np.float64).reshape(-1, 2)
    Q = np.asarray(Q, np.float64).reshape(-1, 2)
    if len(P) == 0:
        return 1.0 + 0j, 0j
    p = P[:, 0] + 1j * P[:, 1]
    q = Q[:, 0] + 1j * Q[:, 1]
    pc, qc = p.mean(), q.mean()
    dp, dq = p - pc, q - qc
    den = float(np.sum(np.abs(dp) ** 2))
    s = complex(np.sum(dp.conj() * dq) / den) if den > 1e-18 else 1.0 + 0j
    if not np.isfinite(s) or abs(s) < 1e-9:
        s = 1.0 + 0j
    return s, complex(qc - s * pc)


def apply_similarity(V, s: complex, t: complex) -> np.ndarray:
    """``s z + t`` applied to points ``V`` (n, 2); returns (n, 2)."""
    V = np.asarray(V, np.float64)
    z = s * (V[:, 0] + 1j * V[:, 1]) + t
    return np.stack([z.real, z.imag], axis=1)


class ModeOps:
    """Operators of the non-rigid modes, on the pattern of ``L`` (see the module docstring).

    With ``p_i = sum_j w_ij e_ij u_ij`` and the per-cell constants below, one iteration's
    blended cell maps are ``sigma = mr q / |q| + c1 q - c2 p - 1`` and
    ``beta = d1 p - d2 q`` (:func:`cell_sigma` in closed form, constants folded once).

    Attributes
    ----------
    G : (n,) complex
        ``sum_j w_ij e_ij^2``.
    T_f, T_b : (n, nf), (n, k) complex csr or None
        ``G + T_f @ x_f + T_b @ x_b`` is ``p`` (None when no cell has an affine part).
    Rc : (nf, n) complex csr or None
        ``Rc @ beta``: the right-hand side of the anti-linear parts ``beta conj(e)``.
    mr : (n,) float
        Rigid weight of each cell; ``rigid`` the cells where it is not 0.
    c1, c2, d1, d2 : (n,) complex
        ``c1 = ms / S0 + ma S0 / det``, ``c2 = ma conj(G) / det``, ``d1 = ma S0 / det``,
        ``d2 = ma G / det`` with ``det = S0^2 - |G|^2`` (0 where a cell has no affine fit).
    """

    def __init__(self, G, T_f, T_b, Rc, mix, S0):
        self.G, self.T_f, self.T_b, self.Rc = G, T_f, T_b, Rc
        mr, ms, ma = mix[:, 0], mix[:, 1], mix[:, 2]
        rest = np.where(S0 > 0, S0, 1.0)
        det = S0 * S0 - (G * G.conj()).real
        ok = det > 1e-12 * np.maximum(S0 * S0, 1e-300)  # collinear spokes: no affine fit, rigid instead
        mr = mr + np.where(ok, 0.0, ma)
        ma = np.where(ok, ma, 0.0)
        det = np.where(ok, det, 1.0)
        self.mr, self.rigid = mr, np.flatnonzero(mr)
        self.c1 = ms / rest + ma * S0 / det
        self.c1a, self.cs = ma * S0 / det, ms / rest  # c1's affine and similar parts
        self.inv_rest = 1.0 / rest
        self.similar = np.flatnonzero(ms)
        self.c2 = ma * G.conj() / det
        self.d1 = ma * S0 / det
        self.d2 = ma * G / det
        self.affine = bool(ma.any())

    def sigma(self, q, p, scale=None):
        """(sigma, beta) of cell values ``q`` and ``p`` (p None without affine cells).
        ``scale``: (lo, hi) bounds of the similar cells' scale (None: unbounded)."""
        if scale is None or not len(self.similar):
            out = self.c1 * q
        else:  # the best similarity with its scale clamped: the exact fit over that set
            out = self.c1a * q
            sim = self.similar
            qs = q[sim]
            size = np.abs(qs) * self.inv_rest[sim]  # the cell's best scale |q| / S0
            size[size == 0] = 1.0
            out[sim] += (self.cs[sim] * qs) * (np.clip(size, scale[0], scale[1]) / size)
        out -= 1.0
        if len(self.rigid) == len(q):  # every cell has a rigid part: no gather/scatter
            r = np.abs(q)
            r[r == 0] = 1.0
            np.divide(self.mr, r, out=r)
            out += r * q
        elif len(self.rigid):
            qr = q[self.rigid]
            r = np.abs(qr)
            r[r == 0] = 1.0
            out[self.rigid] += (self.mr[self.rigid] / r) * qr
        if not self.affine:
            return out, None
        out -= self.c2 * p
        beta = self.d1 * p
        beta -= self.d2 * q
        return out, beta


def mode_operators(data, P, fmap, bmap) -> ModeOps:
    """Build :class:`ModeOps` for ``data`` (an ``ArapData`` whose ``mix`` is set)."""
    n, nf, k = data.n, len(data.free), len(data.b)
    e = data.ev[:, 0] + 1j * data.ev[:, 1]  # on W's entries, in P's row order
    we = data.ew * e
    G2 = we * e
    G = np.bincount(data.ei, weights=G2.real, minlength=n) + 1j * np.bincount(data.ei, weights=G2.imag, minlength=n)
    if not data.mix[:, 2].any():
        return ModeOps(G=G, T_f=None, T_b=None, Rc=None, mix=data.mix, S0=data.S0)
    g = np.bincount(data.ei, weights=we.real, minlength=n) + 1j * np.bincount(data.ei, weights=we.imag, minlength=n)
    T = P.matrix(P.data(-we, g, np.complex128))
    m = data.ew * e.conj()
    Rc = P.block(P.data(0.5 * m, 0.5 * g.conj(), np.complex128), fmap, None, (nf, n))
    if data.k is not None:
        Rc = (Rc @ sp.diags(data.k)).tocsr()
    return ModeOps(G=G, T_f=P.block(T.data, None, fmap, (n, nf)), T_b=P.block(T.data, None, bmap, (n, k)), Rc=Rc,
                   mix=data.mix, S0=data.S0)


def mode_rhs(data, xb, held=None, scale=None):
    """``rhs(x_f)`` of the global step with per-cell mixed modes (``data.mix``), pins at
    displacements ``xb`` (k,) complex; the same factor as rigid ARAP solves it.
    ``held``: ``(cells, rho)``, cells whose map is held at the rotation ``rho`` (unit
    complex numbers; pins with an angle). ``scale``: (lo, hi) bounds of the similar cells'
    scale, None for unbounded."""
    ops = data.modes
    q0 = data.S0 + data.S_b @ xb
    p0 = ops.G + ops.T_b @ xb if ops.affine else None
    rb = data.L_fb @ xb

    def rhs_of(xf):
        q = data.S_f @ xf + q0
        p = ops.T_f @ xf + p0 if ops.affine else None
        sigma, beta = ops.sigma(q, p, scale)
        if held is not None:
            sigma[held[0]] = held[1] - 1.0
            if beta is not None:
                beta[held[0]] = 0.0
        rhs = data.R @ sigma - rb
        if beta is not None:
            rhs += ops.Rc @ beta
        return rhs
    return rhs_of
