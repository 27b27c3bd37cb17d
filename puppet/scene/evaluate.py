"""Pose a built scene: pin targets -> per-layer deformed meshes and depths."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.scene.exterior import GroupExterior
from puppet.scene.model import SceneData, Target
from puppet.scene.solve import PinState, Solver

__all__ = ["PinState", "Solver", "LayerResult", "rest_state", "pose_state", "blend", "evaluate"]


@dataclass
class LayerResult:
    """One layer in one pose: what `puppet mesh` writes and the renderer draws."""

    name: str
    group: int
    order: int
    rest: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    depth: np.ndarray
    pins: dict[str, int]
    exterior: dict[str, list[float]]


def exterior_names(exterior: list[GroupExterior]) -> list[str]:
    return [n for ge in exterior for n in ge.names]


def rest_state(data: SceneData, exterior: list[GroupExterior]) -> PinState:
    j = len(exterior_names(exterior))
    return PinState(to=np.array([p.at for p in data.pins], float).reshape(-1, 2),
                    angle=np.zeros(len(data.pins)), depth=np.array([p.depth for p in data.pins], float),
                    ext_to=np.full((j, 2), np.nan))


def pose_state(data: SceneData, exterior: list[GroupExterior], pose: dict[str, Target]) -> PinState:
    """Pin targets of a named pose's table (pins not named stay at rest; exterior points
    not named ride along with the mesh)."""
    s = rest_state(data, exterior)
    index = {p.name: i for i, p in enumerate(data.pins) if p.kind == "interior"}
    ext = {n: i for i, n in enumerate(exterior_names(exterior))}
    for name, t in pose.items():
        if name in ext:
            if t.to is not None:
                s.ext_to[ext[name]] = t.to
            continue
        i = index[name]
        if t.to is not None:
            s.to[i] = t.to
        s.angle[i] = t.angle
        if t.depth is not None:
            s.depth[i] = t.depth
    return s


def blend(a: PinState, b: PinState, t: float, ext_rest: np.ndarray) -> PinState:
    """Linear blend of two pin states. An exterior point moved in only one of them blends
    from its rest position on the other side (``ext_rest``, (j, 2))."""
    ea, eb = a.ext_to, b.ext_to
    both_free = np.isnan(ea[:, 0]) & np.isnan(eb[:, 0])
    ea = np.where(np.isnan(ea), ext_rest, ea)
    eb = np.where(np.isnan(eb), ext_rest, eb)
    ext = (1 - t) * ea + t * eb
    ext[both_free] = np.nan
    return PinState(to=(1 - t) * a.to + t * b.to, angle=(1 - t) * a.angle + t * b.angle,
                    depth=(1 - t) * a.depth + t * b.depth, ext_to=ext)


def evaluate(data: SceneData, meshes, pin_vertex, groups, solver: Solver, rank: list[int],
             state: PinState) -> list[LayerResult]:
    """Per-layer results of one pose, in scene layer order."""
    out: list[LayerResult | None] = [None] * len(data.layers)
    for gi, g in enumerate(groups):
        U, depth, ext = solver.solve_group(gi, state)
        ge = solver.exterior[gi]
        for li, k in enumerate(g.layers):
            idx = g.mesh.maps[li]
            L = data.layers[k]
            exterior = {n: [float(x) for x in ext[j]] for j, n in enumerate(ge.names) if ge.layers[j] == k}
            out[k] = LayerResult(name=L.name, group=gi, order=rank[k], rest=meshes[k].V, deformed=U[idx],
                                 triangles=meshes[k].F, depth=rank[k] + depth[idx], pins=dict(pin_vertex[k]),
                                 exterior=exterior)
    return out
