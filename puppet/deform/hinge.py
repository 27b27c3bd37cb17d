"""Initial guess for meshes whose parts are joined at single points (hinges).

Object-space MLS over geodesic distance (garment paper §3.1.1) lets every pin pull on
every vertex it reaches; through a hinge that makes a body bend toward an arm turned
about its shoulder, and 20 ARAP iterations do not undo it (35 px on the test arm; 200
iterations would). Here each part is guessed from its own pins plus its hinges, as
articulated figures move:

1. each hinge is placed where the parts that pin it down carry it: the MLS of a part's
   own pins, weighted by (pins - 1), so a part with two pins or more decides and a part
   hanging on one pin follows; when no part has two pins, the MLS of all the pins;
2. each part is then bent by rigid MLS over its own pins and its hinges (two controls,
   a hinge and a tip, turn a part rigidly about the hinge).
"""
from __future__ import annotations

import numpy as np

from puppet.deform.mls import mls_object_space

__all__ = ["hinge_guess"]


def hinge_guess(V, D, P, bc, pin_part, parts, H, DH, *, alpha: float = 1.0) -> np.ndarray:
    """Initial guess of a hinged mesh.

    Parameters
    ----------
    V : (n, 2) float
        Rest vertices (or a similarity of them).
    D : (k, n) float
        Geodesic distances from the pins.
    P : (k, 2) float
        The pins' rest positions (in the frame of V).
    bc : (k, 2) float
        The pins' targets.
    pin_part : (k,) int
        The part of each pin.
    parts : list of (n_l,) int arrays
        Vertices of each part (a hinge belongs to every part it joins).
    H : (h,) int
        Hinge vertices.
    DH : (h, n) float
        Geodesic distances from the hinges.
    alpha : float
        MLS weight exponent.

    Returns
    -------
    U : (n, 2) float
        Pins exactly on ``bc``; a part without pins or hinges takes the plain MLS guess.
    """
    V = np.asarray(V, np.float64)
    U = mls_object_space(V, D, bc, P, kind="rigid", alpha=alpha)
    if len(H) == 0:
        return U
    pin_part = np.asarray(pin_part, np.int64)
    counts = np.bincount(pin_part, minlength=len(parts))
    member = [np.zeros(len(V), bool) for _ in parts]
    for m, idx in zip(member, parts):
        m[idx] = True
    HT = U[H].copy()
    for j, h in enumerate(H):
        acc, wsum = np.zeros(2), 0.0
        for li in range(len(parts)):
            w = counts[li] - 1.0
            if member[li][h] and w > 0:
                sel = pin_part == li
                acc += w * mls_object_space(V[[h]], D[sel][:, [h]], bc[sel], P[sel], kind="rigid", alpha=alpha)[0]
                wsum += w
        if wsum > 0:
            HT[j] = acc / wsum
    for li, idx in enumerate(parts):
        sel = pin_part == li
        hs = np.flatnonzero(member[li][H])
        if sel.sum() + len(hs) == 0:
            continue
        Dl = np.vstack([D[sel][:, idx], DH[hs][:, idx]])
        Q = np.vstack([bc[sel], HT[hs]])
        Pl = np.vstack([P[sel], V[H[hs]]])
        U[idx] = mls_object_space(V[idx], Dl, Q, Pl, kind="rigid", alpha=alpha)
    U[H] = HT
    return U
