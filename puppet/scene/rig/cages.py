"""Caged layers in the rig: a layer with ``layers[i].cage`` is deformed by its cage's map
(:mod:`puppet.deform.cage`), not by the group solver.

Its cage vertices are handles ``LAYER:cageN``, carried as the group's exterior points (the
rows of ``PinState.ext_to``, NaN = not moved), so poses, keys, animation and drags treat
them like exterior points. A pose gives the posed cage: moved handles where the pose puts
them, the others at rest; where the pose moves a pin of the layer, the pins are landmarks
and the cage is the smoothest one carrying them to their targets with the moved handles
held (:func:`~puppet.deform.cage.fit_cage`). The layer's vertices are the cage map of the posed
cage; its depth is the pins' depth field, as for any layer.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.cage import CageFit, CageMap, auto_cage, check_cage, check_encloses, fit_cage
from puppet.errors import SceneError
from puppet.scene.format.model import Cage, Deformer, SceneData
from puppet.scene.rig.solve import GroupPose, GroupPre, finish


@dataclass
class LayerCage:
    """What posing one caged layer (alone in its group) needs: its rest cage, the map of
    the group mesh's vertices, and for pins the pins' map and the fit's energy."""

    layer: int
    rest: np.ndarray  # (m, 2) rest cage, canvas coordinates
    cmap: CageMap  # of the group mesh's vertices
    pins_rest: np.ndarray  # (p, 2) the group's pins at rest, in group pin order
    pin_map: CageMap | None = None
    fit: CageFit | None = None

    def posed(self, bc: np.ndarray, want: np.ndarray) -> np.ndarray:
        """The posed cage for pin targets ``bc`` (p, 2) and handle targets ``want`` (m, 2,
        NaN = not moved)."""
        moved = ~np.isnan(want[:, 0])
        if not len(self.pins_rest) or np.array_equal(bc, self.pins_rest):
            # no pin moved: the cage is posed by its handles alone (held pins would make the
            # fit swing the other handles round them: a dragged handle then moved the dress
            # 2.2 px under green while the cage crossed it)
            return np.where(moved[:, None], want, self.rest)
        C = fit_cage(self.rest, self.cmap.kind, self.pins_rest, bc, fixed=(np.flatnonzero(moved), want[moved]),
                     cage_map=self.pin_map, fit=self.fit)
        C[moved] = want[moved]  # held by the fit to rounding: exactly where the pose puts them
        return C


def rest_cage(data: SceneData, k: int, image) -> np.ndarray:
    """Layer ``k``'s rest cage: its points, or one made from its mask (canvas coordinates)."""
    cage: Cage = data.layers[k].cage
    if cage.points is not None:
        return cage.points
    C = auto_cage(image.mask, cage.auto, cage.offset) + np.asarray(image.offset, np.float64)
    msg = check_cage(C)
    if msg:
        raise SceneError(f"the automatic cage {msg}", file=data.file, path=f"layers[{k}].cage.auto")
    return C


def build_cage(data: SceneData, k: int, rest: np.ndarray, group) -> LayerCage:
    """The caged layer ``k``'s :class:`LayerCage` over its ``group`` (it is the group's only
    layer). Raises SceneError naming ``layers[k].cage`` where the cage leaves the mesh out."""
    path = f"layers[{k}].cage"
    V = group.mesh.V
    msg = check_encloses(rest, V)
    if msg:
        raise SceneError(f"the cage {msg}", file=data.file, path=path)
    kind = data.layers[k].cage.coordinates
    pins_rest = np.array([data.pins[i].at for i in group.pins], np.float64).reshape(-1, 2)
    try:
        cmap = CageMap(rest, V, kind)
        if not len(pins_rest):
            return LayerCage(k, rest, cmap, pins_rest)
        return LayerCage(k, rest, cmap, pins_rest, CageMap(rest, pins_rest, kind), CageFit(rest, kind))
    except ValueError as e:  # a point the coordinates cannot hold (on the cage, by rounding)
        raise SceneError(f"the cage cannot carry the layer: {e}", file=data.file, path=path) from None


def cage_handles(name: str, rest: np.ndarray) -> list[str]:
    """The handle names of a layer's cage vertices, in point order."""
    return [f"{name}:cage{j}" for j in range(len(rest))]


def cage_solve(lc: LayerCage, pre: GroupPre, g, deformer: Deformer, ge, pose: GroupPose):
    """(U, depth, posed cage) of a caged layer's group, as :func:`~puppet.scene.rig.solve.solve_group`
    gives them for other groups (the cage's vertices are the group's exterior points)."""
    C = lc.posed(pose.bc, pose.ext_to)
    U, depth, _ = finish(pre, g, deformer, ge, pose, lc.cmap.apply(C))
    return U, depth, C
