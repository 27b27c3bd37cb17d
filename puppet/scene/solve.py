"""Per-group solvers of a scene: one precomputation per group and pin set (never per
pose), then a solve per pose by the scene's deformer method.

Every pose is solved from its own initial guess (trajectory invariance): nothing of a
previously solved pose is reused but the precomputed factorisations and weights.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.boundary import exterior_positions, fine_deform
from puppet.deform.depth import depth_field
from puppet.deform.igarashi import igarashi_precompute, igarashi_solve
from puppet.deform.mls import mls_object_space
from puppet.deform.relax import relax_foldovers
from puppet.deform.rotate import arap_solve_rotated
from puppet.deform.skeleton import skeleton_precompute, skeleton_solve
from puppet.geom.geodesic import geodesic_distances
from puppet.scene.build import Group
from puppet.scene.exterior import GroupExterior
from puppet.scene.model import SceneData


@dataclass
class PinState:
    """Where every pin is in one pose.

    ``ext_to`` holds one row per exterior point of the scene (``Solver.exterior_names``
    order): the target a pose gave it, or NaN where it rides along with the mesh.
    """

    to: np.ndarray  # (k, 2) targets, scene pin order
    angle: np.ndarray  # (k,) degrees, counter-clockwise on screen
    depth: np.ndarray  # (k,)
    ext_to: np.ndarray  # (j, 2), NaN = not moved by the pose


@dataclass
class GroupPre:
    """What one group needs for every pose."""

    D: np.ndarray  # (k, n) geodesic distances from the group's pins
    arap: object = None
    igarashi: object = None
    skeleton: object = None


class Solver:
    """Precomputes every group once; solves poses."""

    def __init__(self, data: SceneData, groups: list[Group], exterior: list[GroupExterior]):
        self.data = data
        self.groups = groups
        self.exterior = exterior
        self.pre = [self._precompute(g) for g in groups]

    def _precompute(self, g: Group) -> GroupPre:
        d = self.data.deformer
        V, F, b = g.mesh.V, g.mesh.F, g.b
        if d.method in ("arap", "mls"):
            a = arap_precompute(V, F, b, weights=d.weights, alpha=d.alpha)
            return GroupPre(D=a.D, arap=a)
        if d.method == "igarashi":
            return GroupPre(D=geodesic_distances(V, F, b), igarashi=igarashi_precompute(V, F, b))
        local = {self.data.pins[i].name: k for k, i in enumerate(g.pins)}
        bones = np.array([(local[a], local[z]) for a, z in self.data.bones if a in local and z in local],
                         np.int64).reshape(-1, 2)
        sk = skeleton_precompute(V, F, b, bones)
        return GroupPre(D=sk.D, skeleton=sk)

    def solve_group(self, gi: int, state: PinState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Deformed vertices (n, 2), pin-depth field (n,) and exterior positions (j, 2) of group ``gi``."""
        g, pre, d = self.groups[gi], self.pre[gi], self.data.deformer
        V = g.mesh.V
        bc = state.to[g.pins].reshape(-1, 2)
        angles = state.angle[g.pins]
        if len(g.pins) == 0:
            U = V.copy()
        elif d.method == "arap":
            if np.any(angles != 0):
                U = arap_solve_rotated(pre.arap, bc, angles, iterations=d.iterations)
            else:
                U = arap_solve(pre.arap, bc, iterations=d.iterations, U0=None if d.init == "mls" else V)
            U = self._relax(pre, U, bc)
        elif d.method == "mls":
            U = mls_object_space(V, pre.D, bc, V[g.b], kind="rigid", alpha=d.alpha)
            U[pre.arap.held] = V[pre.arap.held]
        elif d.method == "igarashi":
            U = igarashi_solve(pre.igarashi, bc)
        else:
            U = skeleton_solve(pre.skeleton, bc)
        depth = depth_field(pre.D, state.depth[g.pins], alpha=d.alpha) if len(g.pins) else np.zeros(len(V))
        U, ext = self._exterior(gi, U, state)
        return U, depth, ext

    def _relax(self, pre: GroupPre, U: np.ndarray, bc: np.ndarray) -> np.ndarray:
        """Re-solve folded triangles with bounded similarity cells (relaxed ARAP)."""
        if not self.data.deformer.relax_foldovers:
            return U
        return relax_foldovers(pre.arap, U, bc)

    def _exterior(self, gi: int, U: np.ndarray, state: PinState):
        """Exterior points ride along with U; those a pose moves pull the boundary (fine mode)."""
        ge = self.exterior[gi]
        if ge.frame is None:
            return U, np.zeros((0, 2))
        ride = exterior_positions(U, ge.frame)
        start = sum(len(e.names) for e in self.exterior[:gi])
        want = state.ext_to[start:start + len(ge.names)]
        moved = ~np.isnan(want[:, 0])
        target = np.where(moved[:, None], want, ride)
        if moved.any() and not np.array_equal(target, ride):
            g = self.groups[gi]
            U = fine_deform(U, g.mesh.F, g.b, ride, target, mode="points")
        return U, target
