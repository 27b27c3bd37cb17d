"""The target skeleton in relative form (Shen et al. 2010, §4), re-applied on every frame.

Each target bone is stored as a scale and a rotation of its original bone: a bone
``(u, v)`` from ``P_u`` to ``P_v`` on the start frame, posed to ``T_u -> T_v``, is kept as
``alpha = |T_v - T_u| / |P_v - P_u|`` and ``theta = angle(T_v - T_u) - angle(P_v - P_u)``
(the paper's ``(alpha, theta)``). On a frame whose tracked skeleton is ``J``, the bone is
rebuilt as ``alpha R(theta) (J_v - J_u)``, so the edit follows the character as it turns,
grows or shrinks in the picture.

The bones are walked outward from a root (per connected part of the skeleton: the pin
with most bones that the pose leaves in place, else the pin with most bones). The
root's own move is kept in the frame of its first bone (scaled and turned with it). A
bone that closes a loop is not walked (the tree's bones decide). A pin on no bone keeps
its pose offset ``T - P`` as it is.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = ["RelativeSkeleton", "relative_skeleton"]


def _angle(d: np.ndarray) -> np.ndarray:
    return np.arctan2(d[..., 1], d[..., 0])


def _rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class RelativeSkeleton:
    """A target skeleton relative to its original one.

    Attributes
    ----------
    order : list of (parent, child, alpha, theta): tree bones in walking order
        (``parent == -1`` marks the root ``child`` of a part; see ``root_move``).
    root_move : dict root -> (other, (2,) offset): the root's move ``T - P`` in the frame
        of its first bone ``root -> other`` (a similarity: scaled and turned with it).
    loose : dict pin -> (2,) offset ``T - P`` for pins on no bone.
    n : number of pins.
    """

    order: list
    root_move: dict
    loose: dict
    n: int

    def apply(self, J) -> np.ndarray:
        """Target positions ``(n, 2)`` on a frame whose tracked joints are ``J (n, 2)``."""
        J = np.asarray(J, dtype=np.float64).reshape(self.n, 2)
        T = J.copy()
        for pin, off in self.loose.items():
            T[pin] = J[pin] + off
        for parent, child, alpha, theta in self.order:
            if parent < 0:
                other, off = self.root_move[child]
                if other is None:
                    T[child] = J[child] + off
                else:  # the offset lives in the frame of the root's first bone
                    d = J[other] - J[child]
                    T[child] = J[child] + _frame(d) @ off
                continue
            T[child] = T[parent] + alpha * (_rot(theta) @ (J[child] - J[parent]))
        return T


def _frame(d: np.ndarray) -> np.ndarray:
    """Columns: the bone direction and its normal, scaled by the bone length (a similarity)."""
    return np.array([[d[0], -d[1]], [d[1], d[0]]])


def relative_skeleton(P, T, bones) -> RelativeSkeleton:
    """Express the target skeleton ``T`` relative to the original ``P``.

    Parameters
    ----------
    P : (n, 2) float
        Original joints (pins on the start frame).
    T : (n, 2) float
        Target joints (the pose).
    bones : (m, 2) int
        Pin index pairs.

    Returns
    -------
    RelativeSkeleton
        ``apply(P)`` gives back ``T`` (up to rounding); ``apply(S(P))`` gives ``S(T)``
        for every similarity ``S`` of the plane.

    Raises
    ------
    ValueError
        A bone of zero length on the start frame.
    """
    P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    T = np.asarray(T, dtype=np.float64).reshape(-1, 2)
    n = len(P)
    bones = np.asarray(bones, dtype=np.int64).reshape(-1, 2)
    adj: list[list[int]] = [[] for _ in range(n)]
    for u, v in bones:
        if np.linalg.norm(P[v] - P[u]) == 0:
            raise ValueError(f"bone ({u}, {v}) has zero length")
        adj[u].append(int(v))
        adj[v].append(int(u))
    deg = np.array([len(a) for a in adj])
    moved = np.linalg.norm(T - P, axis=1) > 1e-9
    seen = np.zeros(n, bool)
    order, root_move, loose = [], {}, {}
    for i in range(n):
        if deg[i] == 0:
            loose[i] = T[i] - P[i]
            seen[i] = True
    while not seen.all():
        todo = np.flatnonzero(~seen)
        # root: most bones among the pins the pose leaves in place, else most bones
        still = todo[~moved[todo]]
        pool = still if len(still) else todo
        root = int(pool[np.argmax(deg[pool])])
        other = adj[root][0]
        d = P[other] - P[root]
        off = np.linalg.solve(_frame(d), T[root] - P[root])
        root_move[root] = (other, off)
        order.append((-1, root, 1.0, 0.0))
        seen[root] = True
        queue = deque([root])
        while queue:
            u = queue.popleft()
            for v in adj[u]:
                if seen[v]:
                    continue
                seen[v] = True
                o, t = P[v] - P[u], T[v] - T[u]
                alpha = float(np.linalg.norm(t) / np.linalg.norm(o))
                theta = float(_angle(t) - _angle(o)) if alpha > 0 else 0.0
                order.append((u, v, alpha, theta))
                queue.append(v)
    return RelativeSkeleton(order=order, root_move=root_move, loose=loose, n=n)
