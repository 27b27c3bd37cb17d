"""Merge layer meshes into one group mesh, sharing the vertices along link segments."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


class UnionFind:
    """Disjoint sets over 0..n-1 with path halving."""

    def __init__(self, n: int):
        self.parent = np.arange(n)

    def find(self, i: int) -> int:
        p = self.parent
        while p[i] != i:
            p[i] = p[p[i]]
            i = p[i]
        return int(i)

    def union(self, i: int, j: int) -> None:
        a, b = self.find(i), self.find(j)
        if a != b:
            self.parent[max(a, b)] = min(a, b)

    def labels(self) -> np.ndarray:
        """Dense component label per element, in order of first appearance."""
        roots = self.parent.copy()
        while True:  # pointer jumping, vectorised: every element to its root
            up = roots[roots]
            if np.array_equal(up, roots):
                break
            roots = up
        _, lab = np.unique(roots, return_inverse=True)
        return lab


@dataclass
class GroupMesh:
    """One deformation problem: the union of several layer meshes.

    V : (n, 2) group vertices. F : (m, 3) group triangles.
    maps : per layer, (n_layer,) indices of its vertices in V.
    """

    V: np.ndarray
    F: np.ndarray
    maps: list[np.ndarray]


def merge_meshes(meshes, shared: list[tuple[int, int, int, int]]) -> GroupMesh:
    """Concatenate meshes and identify shared vertices.

    Parameters
    ----------
    meshes : sequence of (V_l (n_l, 2), F_l (m_l, 3)).
    shared : (mesh a, vertex i, mesh b, vertex j) quadruples: vertex i of mesh a is the
        same point as vertex j of mesh b (a link vertex present in both).

    Returns
    -------
    GroupMesh whose vertices are the meshes' vertices with shared ones merged.
    """
    starts = np.cumsum([0] + [len(V) for V, _ in meshes])
    uf = UnionFind(int(starts[-1]))
    for a, i, b, j in shared:
        uf.union(int(starts[a] + i), int(starts[b] + j))
    lab = uf.labels()
    allV = np.concatenate([V for V, _ in meshes]) if meshes else np.zeros((0, 2))
    V = np.zeros((lab.max() + 1 if len(lab) else 0, 2))
    V[lab] = allV
    F = np.concatenate([lab[starts[k] + F_l] for k, (_, F_l) in enumerate(meshes)]) if meshes else np.zeros((0, 3), int)
    maps = [lab[starts[k]:starts[k + 1]] for k in range(len(meshes))]
    return GroupMesh(V=V, F=F, maps=maps)
