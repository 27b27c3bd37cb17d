"""Object-space MLS with skeleton-based compact weights (the ``mls-skeleton`` deformer).

Pins (control points) are mesh vertices ``b``; bones are pairs of pins. Each pin only
influences the part of the shape its bones say it owns, so dragging a hand does not
move the head. Distances are interior (geodesic along mesh edges).

Ranges, after Shen, Ma and Liu 2010 ("An MLS-based cartoon deformation", §3, eq. 10-13),
with ``k`` = 1.2 (the paper's value) and ``D[i]`` = interior distance from pin i:

* bone length ``l_e`` = interior distance between its two pins (Euclidean if the two
  pins are in different components);
* reach of pin ``u`` along its bone to ``v``: ``rho_uv = l_uv`` when ``v`` ends the
  skeleton there (one bone), else ``l_uv + min(other bones of v) / 2`` (eq. 11: the
  range ends halfway along the next bone);
* an end pin (one bone) has the isotropic range ``k rho`` of its one reach (eq. 11);
* a joint (two bones or more) is anisotropic (eq. 12): around the joint, the bone
  directions cut the plane into sectors; a vertex in the sector from bone direction 1
  to 2 (opening ``Theta``) at angle ``t`` from direction 1 gets ``k (rho_1 cos(pi t /
  (2 Theta)) + rho_2 sin(pi t / (2 Theta)))``: each bone's reach along it, blended in between;
* a pin without bones (the paper has none) takes the interior distance to the nearest
  other pin; a pin that reaches no other pin has range ``inf`` (global support).

``R[i, v]`` is pin i's range at vertex v; ``r[i]`` its longest reach along a bone (times ``k``).

Weights (eq. 13): ``w_i(v) = max(1/D_i(v)^2 - 1/(lam(v) R[i, v])^2, 0)`` (compact support,
one-hot at the pin vertex itself). The paper asks that every point be controlled by
at least two pins and chooses the ranges for it; where they do not overlap enough
(shapes the paper did not meet) ``lam(v) = max(1, rho2(v) / 0.8)`` where ``rho2`` is the
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
    r : (k,) each pin's longest reach along a bone times ``k`` (an end pin's range in every
        direction; a pin without bones: ``k`` times the distance to the nearest pin).
    R : (k, n) each pin's range at each vertex (eq. 11-12, ``k`` included).
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


def _reaches(b, bones, ell):
    """Per pin: list of (other pin, reach along the bone to it) (eq. 11-12)."""
    n_pins = len(b)
    nbrs: list[list[tuple[int, float]]] = [[] for _ in range(n_pins)]
    for (i, j), le in zip(bones, ell):
        nbrs[i].append((int(j), float(le)))
        nbrs[j].append((int(i), float(le)))
    reach: list[list[tuple[int, float]]] = [[] for _ in range(n_pins)]
    for u in range(n_pins):
        for v, le in nbrs[u]:
            beyond = [lv for w, lv in nbrs[v] if w != u]
            reach[u].append((v, le + (min(beyond) / 2.0 if beyond else 0.0)))
    return reach


def _ranges(V, D, b, bones, ell, k):
    """``(r, R)``: each pin's largest range (k, ) and its range at every vertex (k, n)."""
    n_pins, n = len(b), V.shape[0]
    reach = _reaches(b, bones, ell)
    R = np.full((n_pins, n), np.inf)
    r = np.full(n_pins, np.inf)
    for i in range(n_pins):
        if reach[i]:
            r[i] = k * max(rho for _, rho in reach[i])
        if len(reach[i]) == 1:  # an end pin: isotropic
            R[i] = r[i]
        elif len(reach[i]) >= 2:
            R[i] = k * _sector_ranges(V, V[b[i]], [(V[b[j]], rho) for j, rho in reach[i]])
        else:  # no bones: the nearest other pin
            d = D[i, b]
            d = d[np.isfinite(d) & (d > 0)]
            if len(d):
                R[i] = r[i] = k * d.min()
    return r, R


def _sector_ranges(V, a, arms) -> np.ndarray:
    """Eq. 12: the range of a joint at ``a`` toward every vertex, from its bones' reaches.

    ``arms``: (other end, reach) per bone. A vertex at angle ``t`` into the sector between
    consecutive bone directions 1 and 2 (opening ``Theta``) gets
    ``rho_1 cos(pi t / (2 Theta)) + rho_2 sin(pi t / (2 Theta))``.
    """
    phi = np.array([np.arctan2(e[1] - a[1], e[0] - a[0]) for e, _ in arms]) % (2 * np.pi)
    rho = np.array([r for _, r in arms])
    order = np.lexsort((-rho, phi))
    phi, rho = phi[order], rho[order]
    keep = np.r_[True, np.diff(phi) > 1e-12]  # bones along one direction: the longest reach
    phi, rho = phi[keep], rho[keep]
    theta = np.arctan2(V[:, 1] - a[1], V[:, 0] - a[0]) % (2 * np.pi)
    if len(phi) == 1:
        return np.full(len(V), rho[0])
    s = np.searchsorted(phi, theta, side="right") - 1  # sector start (-1: wraps from the last)
    s = np.where(s < 0, len(phi) - 1, s)
    e = (s + 1) % len(phi)
    opening = (phi[e] - phi[s]) % (2 * np.pi)
    t = (theta - phi[s]) % (2 * np.pi)
    x = np.pi * t / (2 * opening)
    return rho[s] * np.cos(x) + rho[e] * np.sin(x)


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
    r, R = _ranges(V, D, b, bones, ell, k)
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
