"""Object-space MLS with skeleton-based compact weights (the ``mls-skeleton`` deformer).

Pins (control points) are mesh vertices ``b``; bones are pairs of pins. Each pin only
influences the part of the shape its bones say it owns, so dragging a hand does not
move the head. Distances are interior (geodesic along mesh edges).

Ranges (``k`` = 1.2 by default, ``D[i]`` = interior distance from pin i):

* bone length ``l_e`` = interior distance between its two pins (Euclidean if the two
  pins are in different components);
* degree rules, isotropic range ``r_i = k * rho_i``: a pin with bones takes ``rho_i`` =
  the mean length of its incident bones (an end pin: its one bone; a joint: the mean);
  a pin without bones takes the interior distance to the nearest other pin; a pin
  that reaches no other pin has ``r_i = inf`` (global support);
* bone bodies (anisotropic range): for a bone e = (i, j) and a vertex v with Euclidean
  projection parameter ``s`` on the segment (0 at pin i, clamped to [0, 1]) and
  membership ``tau = clip((k l_e - D_i(v) - D_j(v)) / ((k - 1) l_e), 0, 1)`` (1 on the
  bone, 0 outside the interior-distance ellipse with foci at the pins), pin i's range
  at v is raised to ``r_i + s tau max(k l_e - r_i, 0)`` (and pin j's with ``1 - s``):
  interpolated along the bone from the pin's own range to ``k l_e`` at the far pin, so
  the weights of both pins cover the whole bone body. ``R[i, v]`` is the largest of the
  isotropic and bone ranges.

Weights: ``w_i(v) = max(1/D_i(v)^2 - 1/(lam(v) R[i, v])^2, 0)`` (compact support, one-hot
at the pin vertex itself). ``lam(v) = max(1, rho2(v) / 0.8)`` where ``rho2`` is the
second smallest of ``D_i(v) / R[i, v]``: 1 wherever two pins cover v with margin, and
otherwise just large enough that the two nearest pins (in units of their ranges) do.
This is the fallback for vertices no pin reaches (far from every range it tends to
inverse-distance weights over the nearest pins); it is continuous, and it gives every
vertex at least two controls, which a rigid fit needs to rotate (one control only
translates). Vertices no pin reaches along the mesh (other components) use Euclidean
distances instead. The closed forms are :func:`puppet.deform.mls.mls_from_weights`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.mls import KINDS, mls_from_weights
from puppet.deform.threads import blas_capped
from puppet.geom.geodesic import geodesic_distances
from puppet.geom.mesh import check_mesh

__all__ = ["SkeletonData", "skeleton_precompute", "skeleton_from_distances", "skeleton_solve",
           "skeleton_weights", "mls_skeleton"]

COVER = 0.8  # every vertex lies within COVER * lam * R of at least two pins


@dataclass(frozen=True)
class SkeletonData:
    """Everything a drag needs; built once per mesh, pins and bones.

    Attributes
    ----------
    V : (n, 2) rest vertices.
    b : (k,) pin vertex indices; ``p = V[b]`` their rest positions.
    bones : (m, 2) pin index pairs (deduplicated, i < j).
    D : (k, n) interior distances from the pins (Euclidean in columns no pin reaches).
    lengths : (m,) bone lengths.
    r : (k,) isotropic ranges (degree rules, ``k`` included).
    R : (k, n) ranges after the bone bodies.
    lam : (n,) coverage widening factor (1 where two pins cover the vertex).
    W : (k, n) weights, columns scaled to max 1.
    exact : (n,) pin at distance 0 from the vertex (first one), -1 if none.
    """

    V: np.ndarray
    b: np.ndarray
    bones: np.ndarray
    D: np.ndarray
    lengths: np.ndarray
    r: np.ndarray
    R: np.ndarray
    lam: np.ndarray
    W: np.ndarray
    exact: np.ndarray

    @property
    def p(self) -> np.ndarray:
        return self.V[self.b]


def _check(V, F, b, bones, k):
    V, F, b = check_mesh(V, F, b)
    bones = np.asarray(bones, dtype=np.int64).reshape(-1, 2)
    if len(bones) and (bones.min() < 0 or bones.max() >= len(b)):
        raise ValueError(f"bones must index pins 0..{len(b) - 1}")
    if (bones[:, 0] == bones[:, 1]).any():
        raise ValueError("a bone must join two different pins")
    if not k > 1:
        raise ValueError(f"k must be > 1 (a range must cover its bone), got {k}")
    bones = np.unique(np.sort(bones, axis=1), axis=0)
    return V, F, b, bones


def _distances(V, F, b):
    """Geodesic distances; Euclidean for vertex columns that no pin reaches."""
    D = geodesic_distances(V, F, b)
    lost = ~np.isfinite(D).any(axis=0)
    if lost.any() and len(b):
        P = V[b]
        D[:, lost] = np.hypot(P[:, 0, None] - V[None, lost, 0], P[:, 1, None] - V[None, lost, 1])
    return D


def _bone_lengths(V, D, b, bones):
    i, j = bones.T
    ell = 0.5 * (D[i, b[j]] + D[j, b[i]])
    euclid = np.linalg.norm(V[b[i]] - V[b[j]], axis=1)
    ell = np.where(np.isfinite(ell), ell, euclid)
    if (ell <= 0).any():
        raise ValueError("a bone joins two pins on the same vertex")
    return ell


def _isotropic_ranges(D, b, bones, ell, k):
    """Degree rules: mean incident bone length; nearest other pin; inf."""
    n_pins = len(b)
    deg = np.bincount(bones.ravel(), minlength=n_pins)
    total = np.bincount(bones.ravel(), weights=np.repeat(ell, 2), minlength=n_pins)
    rho = np.full(n_pins, np.inf)
    rho[deg > 0] = total[deg > 0] / deg[deg > 0]
    for i in np.flatnonzero(deg == 0):
        d = D[i, b]
        d = d[np.isfinite(d) & (d > 0)]
        if len(d):
            rho[i] = d.min()
    return k * rho


def _bone_ranges(V, D, b, bones, ell, r, k):
    """Raise each pin's range along its bones' bodies (see module docstring)."""
    R = np.repeat(r[:, None], V.shape[0], axis=1)
    for (i, j), le in zip(bones, ell):
        a, e = V[b[i]], V[b[j]] - V[b[i]]
        ee = e @ e
        s = np.clip(((V - a) @ e) / ee, 0.0, 1.0) if ee > 0 else np.full(len(V), 0.5)
        with np.errstate(invalid="ignore"):
            tau = np.clip((k * le - D[i] - D[j]) / ((k - 1.0) * le), 0.0, 1.0)
        tau = np.nan_to_num(tau, nan=0.0)
        for pin, frac in ((i, s), (j, 1.0 - s)):
            if np.isfinite(r[pin]) and k * le > r[pin]:
                R[pin] = np.maximum(R[pin], r[pin] + frac * tau * (k * le - r[pin]))
    return R


def _compact_weights(D, R):
    """Compact weights with coverage widening; (W scaled to column max 1, lam, exact)."""
    n_pins, n = D.shape
    if n_pins == 0:
        return np.zeros((0, n)), np.ones(n), np.full(n, -1, dtype=np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(np.isinf(D), np.inf, np.where(D == 0, 0.0, D / R))  # R inf -> 0
        rho2 = np.partition(ratio, 1, axis=0)[1] if n_pins > 1 else np.zeros(n)
        lam = np.maximum(1.0, rho2 / COVER)
        W = np.maximum(1.0 / D**2 - 1.0 / (lam * R) ** 2, 0.0)
    zero = D == 0
    exact = np.where(zero.any(axis=0), zero.argmax(axis=0), -1).astype(np.int64)
    cols = np.flatnonzero(exact >= 0)
    W[:, cols] = 0.0
    W[exact[cols], cols] = 1.0
    W = np.nan_to_num(W, nan=0.0, posinf=0.0)
    top = W.max(axis=0, initial=0.0)
    W /= np.where(top > 0, top, 1.0)
    return W, lam, exact


@blas_capped
def skeleton_precompute(V, F, b, bones, *, k: float = 1.2) -> SkeletonData:
    """Distances, ranges and compact weights of a skeleton over pins (the expensive part).

    Parameters
    ----------
    V : (n, 2) float
        Rest vertices.
    F : (m, 3) int
        Triangles (interior distances run along their edges).
    b : (k,) int
        Pin vertex indices.
    bones : (m, 2) int
        Pairs of pin indices (into ``b``); duplicates and order are ignored.
    k : float
        Range factor (> 1): a range is ``k`` times the bone length it comes from.

    Returns
    -------
    SkeletonData
        See the class; ``skeleton_solve`` only uses ``V``, ``b``, ``W`` and ``exact``.
    """
    V, F, b, bones = _check(V, F, b, bones, k)
    return skeleton_from_distances(V, b, bones, _distances(V, F, b), k=k)


def skeleton_from_distances(V, b, bones, D, *, k: float = 1.2) -> SkeletonData:
    """Ranges and compact weights from interior distances computed elsewhere (e.g. over a
    frame's pixel mask rather than along mesh edges).

    Parameters
    ----------
    V : (n, 2) float. b : (k,) int pin vertices. bones : (m, 2) int pin index pairs.
    D : (k, n) float
        Interior distance from each pin to each vertex (0 at the pin's own vertex, finite).
    k : float
        Range factor (> 1).
    """
    V = np.asarray(V, dtype=np.float64)
    b = np.asarray(b, dtype=np.int64).reshape(-1)
    bones = np.asarray(bones, dtype=np.int64).reshape(-1, 2)
    if len(bones):
        bones = np.unique(np.sort(bones, axis=1), axis=0)
    D = np.asarray(D, dtype=np.float64).reshape(len(b), len(V))
    ell = _bone_lengths(V, D, b, bones)
    r = _isotropic_ranges(D, b, bones, ell, k)
    R = _bone_ranges(V, D, b, bones, ell, r, k)
    W, lam, exact = _compact_weights(D, R)
    return SkeletonData(V=V, b=b, bones=bones, D=D, lengths=ell, r=r, R=R, lam=lam,
                        W=W, exact=exact)


def skeleton_weights(V, F, b, bones, *, k: float = 1.2) -> np.ndarray:
    """Skeleton-based compact weights ``W (k, n)``, columns scaled to max 1.

    Non-negative; ``W[i, v] == 0`` wherever ``D_i(v) >= lam(v) R[i, v]``; a pin vertex's
    column is one-hot on that pin. See :func:`skeleton_precompute` and the module notes.
    """
    return skeleton_precompute(V, F, b, bones, k=k).W


@blas_capped
def skeleton_solve(data: SkeletonData, q, *, kind: str = "rigid") -> np.ndarray:
    """Deform with precomputed skeleton weights (cheap: no distances, no weights).

    Parameters
    ----------
    data : SkeletonData
    q : (k, 2) float
        Pin targets.
    kind : {"rigid", "similarity", "affine"}

    Returns
    -------
    U : (n, 2) float
        Deformed vertices; pin vertices land exactly on ``q``; ``q == V[b]`` returns ``V``
        (exactly for rigid and similarity).
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    q = np.asarray(q, dtype=np.float64).reshape(-1, 2)
    if len(q) != len(data.b):
        raise ValueError(f"q must have shape ({len(data.b)}, 2), got {q.shape}")
    U = data.V.copy()
    if len(q) == 0:
        return U
    todo = data.exact < 0
    if todo.any():
        U[todo] = mls_from_weights(data.V[todo], data.p, q, data.W[:, todo], kind=kind)
    hit = ~todo
    U[hit] = q[data.exact[hit]]
    return U


def mls_skeleton(V, F, b, bones, q, *, k: float = 1.2, kind: str = "rigid") -> np.ndarray:
    """One-shot ``skeleton_solve(skeleton_precompute(V, F, b, bones, k=k), q, kind=kind)``."""
    return skeleton_solve(skeleton_precompute(V, F, b, bones, k=k), q, kind=kind)
