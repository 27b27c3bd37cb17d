"""Lighter meshes for an export (``--simplify PX``): a layer meshed again with bigger
triangles, its vertices carried by the solved mesh.

The layer's own mesh (the one puppet solves) is dense: about 2000 triangles by default.
A coarser mesh of the same outline (the layer's mask regions and its own outline
tolerance, so the drawn edge stays where it was), :data:`FACTOR` times the layer's
triangle area, follows the solved one: each coarse vertex is where the solved mesh takes
its rest position (barycentric coordinates ``W`` in the layer's triangle that holds it).
What the coarse mesh draws is off where the solved mesh bends inside a coarse triangle:
that is measured over every frame exported, each solved vertex placed in the coarse rest
mesh (barycentric ``B``) against where the solved mesh has it, ``|(B W - I) X|``. Where
that is over the pixels asked for, the worst solved vertices (a few, spread apart) are
added to the coarse mesh as vertices and it is made again (at most :data:`ROUNDS`
times); a layer that does not get within them keeps its own mesh (the mesher does not
split an outline edge, so a solved vertex on the outline between two coarse outline
vertices cannot be added: where the outline bends there, the layer keeps its mesh).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from puppet.geom.triangulate import edge_length_for_area, triangulate_regions
from puppet.scene.rig.build import default_max_area
from puppet.scene.rig.reduced import barycentric_matrix

#: The coarse mesh's first triangle area, times the layer's own.
FACTOR = 16.0
#: Most remeshings of one layer.
ROUNDS = 10
#: Most vertices added a round.
ADDED = 40


@dataclass(frozen=True)
class Coarse:
    """A layer's coarser mesh: rest vertices ``V`` (c, 2), triangles ``F``, ``W`` (c, n)
    taking the layer's solved vertices to these, and ``error``: the most a solved vertex
    is off when drawn by it, over the frames measured (pixels)."""

    V: np.ndarray
    F: np.ndarray
    W: sp.csr_matrix
    error: float


def coarser(scene, k: int, rest: np.ndarray, triangles: np.ndarray, frames: np.ndarray,
            px: float) -> Coarse | None:
    """A coarser mesh of layer ``k`` of ``scene`` that draws within ``px`` of the layer's
    solved mesh (``rest`` (n, 2), ``triangles``) in every frame of ``frames`` (m, n, 2:
    positions, or offsets from ``rest``), or None (none found with fewer vertices)."""
    built = scene.built
    regions = built.regions[k] if built.regions is not None else None
    if not regions or len(rest) < 8:
        return None
    L = built.data.layers[k]
    area = (L.mesh.max_area or default_max_area(built.images[k].mask)) * FACTOR
    X = np.moveaxis(np.asarray(frames, np.float64), 0, 1).reshape(len(rest), -1)  # (n, m * 2)
    apart = edge_length_for_area(area) / 3
    points = np.zeros((0, 2))
    best = np.inf
    for _ in range(ROUNDS):
        mesh = triangulate_regions(regions, max_area=area, min_angle=L.mesh.min_angle, simplify=L.mesh.simplify,
                                   points=points)
        if len(mesh.V) >= len(rest):
            return None
        W = barycentric_matrix(mesh.V, rest, triangles)
        off = barycentric_matrix(rest, mesh.V, mesh.F) @ (W @ X) - X
        err = np.sqrt((off.reshape(len(rest), -1, 2) ** 2).sum(axis=2)).max(axis=1) if X.size else np.zeros(len(rest))
        if err.max() <= px:
            return Coarse(mesh.V, np.asarray(mesh.F, np.int64), W.tocsr(), float(err.max()))
        if err.max() > 0.99 * best:  # no better for the vertices added: they do not help
            return None
        best = float(err.max())
        added = _spread(rest, np.flatnonzero(err > 0.5 * px), err, apart)
        points = np.concatenate([points, rest[added]])
        apart /= 1.5
    return None


def _spread(rest: np.ndarray, bad: np.ndarray, err: np.ndarray, apart: float) -> np.ndarray:
    """Up to :data:`ADDED` of the vertices ``bad``, worst first, each at least ``apart``
    from those taken before."""
    taken: list[int] = []
    for v in bad[np.argsort(-err[bad], kind="stable")]:
        if all(np.hypot(*(rest[v] - rest[t])) > apart for t in taken):
            taken.append(int(v))
            if len(taken) >= ADDED:
                break
    return np.asarray(taken, np.int64)
