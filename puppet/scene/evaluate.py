"""Pose a built scene: pin targets -> per-layer deformed meshes and depths.

Every pose is solved from its own initial guess (trajectory invariance): nothing of a
previously solved pose is reused but the precomputed factorisations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.arap import ArapData, arap_precompute, arap_solve
from puppet.deform.depth import depth_field
from puppet.deform.mls import mls_object_space
from puppet.scene.build import Group
from puppet.scene.model import SceneData, Target


@dataclass
class PinState:
    """Where every pin is in one pose."""

    to: np.ndarray  # (k, 2) targets, scene pin order
    angle: np.ndarray  # (k,) degrees
    depth: np.ndarray  # (k,)


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


def rest_state(data: SceneData) -> PinState:
    return PinState(to=np.array([p.at for p in data.pins]).reshape(-1, 2),
                    angle=np.zeros(len(data.pins)), depth=np.array([p.depth for p in data.pins], float))


def pose_state(data: SceneData, pose: dict[str, Target]) -> PinState:
    """Pin targets of a named pose's table (pins not named stay at rest)."""
    s = rest_state(data)
    index = {p.name: i for i, p in enumerate(data.pins)}
    for name, t in pose.items():
        if name not in index:
            continue  # automatic exterior points: not applied yet
        i = index[name]
        if t.to is not None:
            s.to[i] = t.to
        s.angle[i] = t.angle
        if t.depth is not None:
            s.depth[i] = t.depth
    return s


def blend(a: PinState, b: PinState, t: float) -> PinState:
    """Linear blend of two pin states (targets, angles and depths)."""
    return PinState(to=(1 - t) * a.to + t * b.to, angle=(1 - t) * a.angle + t * b.angle,
                    depth=(1 - t) * a.depth + t * b.depth)


class Solver:
    """Per-group precomputation (one factorisation per group and pin set) and solves."""

    def __init__(self, data: SceneData, groups: list[Group]):
        self.data = data
        self.groups = groups
        d = data.deformer
        self.pre: list[ArapData] = [
            arap_precompute(g.mesh.V, g.mesh.F, g.b, weights=d.weights, alpha=d.alpha) for g in groups]

    def solve_group(self, gi: int, state: PinState) -> tuple[np.ndarray, np.ndarray]:
        """Deformed vertices (n, 2) and pin-depth field (n,) of group ``gi``."""
        g, pre, d = self.groups[gi], self.pre[gi], self.data.deformer
        bc = state.to[g.pins].reshape(-1, 2)
        if len(g.pins) == 0:
            U = g.mesh.V.copy()
        elif d.method == "mls":
            U = mls_object_space(g.mesh.V, pre.D, bc, g.mesh.V[g.b], kind="rigid", alpha=d.alpha)
            U[pre.held] = g.mesh.V[pre.held]
        else:
            U0 = None if d.init == "mls" else g.mesh.V
            U = arap_solve(pre, bc, iterations=d.iterations, U0=U0)
        depth = depth_field(pre.D, state.depth[g.pins], alpha=d.alpha) if len(g.pins) else np.zeros(len(U))
        return U, depth


def evaluate(data: SceneData, meshes, pin_vertex, groups: list[Group], solver: Solver, rank: list[int],
             state: PinState) -> list[LayerResult]:
    """Per-layer results of one pose, in scene layer order."""
    out: list[LayerResult | None] = [None] * len(data.layers)
    for gi, g in enumerate(groups):
        U, depth = solver.solve_group(gi, state)
        for li, k in enumerate(g.layers):
            idx = g.mesh.maps[li]
            L = data.layers[k]
            ext = {p.name: [float(x) for x in state.to[i]]
                   for i, p in enumerate(data.pins) if p.layer == L.name and p.kind == "exterior"}
            out[k] = LayerResult(name=L.name, group=gi, order=rank[k], rest=meshes[k].V, deformed=U[idx],
                                 triangles=meshes[k].F, depth=rank[k] + depth[idx], pins=dict(pin_vertex[k]),
                                 exterior=ext)
    return out
