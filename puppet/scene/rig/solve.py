"""One linked group's solver: a precomputation per group mesh and pin set (never per
pose), then a solve per pose by the scene's deformer method.

Every exact pose is solved from its own initial guess (trajectory invariance): nothing
of a previously solved pose is reused but the precomputed factorisations and weights.
Only :func:`preview_group` (used while a pin is dragged) warm-starts from the previous
frame, trading a little accuracy for speed; the drag's final frame is exact.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.boundary import exterior_positions, fine_deform
from puppet.deform.depth import depth_field
from puppet.deform.hinge import HingeWeights, hinge_guess, hinge_weights
from puppet.deform.mls import DistanceWeights, distance_weights, mls_object_space
from puppet.deform.modes import SCALE_SPAN, apply_similarity, mode_mix, similarity_fit, stiffness_from_grey
from puppet.deform.relax import relax_foldovers
from puppet.geom.geodesic import geodesic_distances
from puppet.scene.format.model import Deformer
from puppet.scene.rig.build import Group
from puppet.scene.rig.exterior import GroupExterior


@dataclass
class PinState:
    """Where every pin is in one pose.

    ``ext_to`` holds one row per exterior point of the scene (groups in order, each
    group's points in :class:`GroupExterior` order): the target a pose gave it, or NaN
    where it rides along with the mesh.
    """

    to: np.ndarray  # (k, 2) targets, scene pin order
    angle: np.ndarray  # (k,) degrees, counter-clockwise on screen
    depth: np.ndarray  # (k,)
    ext_to: np.ndarray  # (j, 2), NaN = not moved by the pose


@dataclass
class GroupPose:
    """The part of a :class:`PinState` that one group sees."""

    bc: np.ndarray  # (k_g, 2) targets of the group's pins
    angle: np.ndarray  # (k_g,)
    depth: np.ndarray  # (k_g,)
    ext_to: np.ndarray  # (j_g, 2), NaN = rides along


@dataclass
class GroupPre:
    """What one group needs for every pose."""

    D: np.ndarray  # (k, n) geodesic distances from the group's pins
    arap: object = None
    prefit: bool = False  # every cell 'similar': start from the pins' best similarity
    DH: np.ndarray | None = None  # (h, 2, n) geodesic distances from both sides of the group's hinges
    igarashi: object = None
    skeleton: object = None

    def weights(self, alpha: float) -> DistanceWeights:
        """The inverse-distance weights over ``D`` (of the MLS guess and the depth field):
        pose-independent, so computed once per group version and kept."""
        if self.arap is not None and self.arap.alpha == alpha and self.arap.D is self.D:
            return self.arap.mls_weights()
        kept = self.__dict__.get("_weights")
        if kept is None or kept[0] != alpha:
            kept = self.__dict__["_weights"] = (alpha, distance_weights(self.D, alpha=alpha))
        return kept[1]

    def hinge_weights(self, g: Group, alpha: float) -> HingeWeights:
        """The weights of the hinged guess (:func:`~puppet.deform.hinge.hinge_weights`) of
        group ``g`` (the group of this precomputation), computed once and kept."""
        kept = self.__dict__.get("_hinge_weights")
        if kept is None or kept[0] != alpha:
            kept = self.__dict__["_hinge_weights"] = (alpha, hinge_weights(
                self.D, g.pin_part, g.mesh.maps, g.hinges, self.DH, alpha=alpha))
        return kept[1]


def precompute_group(g: Group, deformer: Deformer, bones: np.ndarray, cells=None) -> GroupPre:
    """Factorisations and weights of one group (``bones``: (nb, 2) indices into the group's
    pins; ``cells``: (grey (n,) or None, mode per vertex) from :mod:`puppet.scene.rig.stiffness`)."""
    V, F, b = g.mesh.V, g.mesh.F, g.b
    if deformer.method in ("arap", "mls"):
        grey, modes = cells if cells is not None else (None, [deformer.mode] * len(V))
        stiff = None if grey is None else stiffness_from_grey(grey)
        mix = None
        if deformer.method == "arap" and any(m != "rigid" for m in modes):
            mix = mode_mix(modes, None if grey is None else grey / 255.0)
        couple = (g.couple, g.kappa) if len(g.couple) else None
        a = arap_precompute(V, F, b, weights=deformer.weights, alpha=deformer.alpha,
                            stiffness=stiff if deformer.method == "arap" else None, mix=mix, couple=couple)
        H = g.hinges.reshape(-1)
        DH = geodesic_distances(V, F, H).reshape(-1, 2, len(V)) if len(H) else None
        return GroupPre(D=a.D, arap=a, prefit=mix is not None and all(m == "similar" for m in modes), DH=DH)
    if deformer.method == "igarashi":
        from puppet.deform.igarashi import igarashi_precompute  # lazy: only scenes of this method load it

        return GroupPre(D=geodesic_distances(V, F, b), igarashi=igarashi_precompute(V, F, b))
    from puppet.deform.skeleton import skeleton_precompute  # lazy: only scenes of this method load it

    sk = skeleton_precompute(V, F, b, bones)
    return GroupPre(D=sk.D, skeleton=sk)


def solve_group(pre: GroupPre, g: Group, deformer: Deformer, ext: GroupExterior,
                pose: GroupPose, *, warm: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Deformed vertices (n, 2), pin-depth field (n,) and exterior positions (j, 2) of one group.

    ``warm`` (n, 2): where an accelerated solve (``deformer.accelerate``) starts instead of
    the MLS guess, e.g. the group's last drag preview; the default loop ignores it."""
    V, bc = g.mesh.V, pose.bc
    if len(g.pins) == 0:
        U = V.copy()
    elif deformer.method == "arap":
        if np.any(pose.angle != 0):
            U = _rotated_pose(pre, g, deformer, bc, pose.angle)
        else:
            U = _arap_pose(pre, g, deformer, bc, warm)
        if deformer.relax_foldovers:
            U = relax_foldovers(pre.arap, U, bc)
    elif deformer.method == "mls":
        U = mls_object_space(V, pre.D, bc, V[g.b], kind="rigid", alpha=deformer.alpha,
                             weights=pre.weights(deformer.alpha))
        U[pre.arap.held] = V[pre.arap.held]
    elif deformer.method == "igarashi":
        from puppet.deform.igarashi import igarashi_solve  # lazy: only scenes of this method load it

        U = igarashi_solve(pre.igarashi, bc)
    else:
        from puppet.deform.skeleton import skeleton_solve  # lazy: only scenes of this method load it

        U = skeleton_solve(pre.skeleton, bc)
    return finish(pre, g, deformer, ext, pose, U)


def _rotated_pose(pre: GroupPre, g: Group, deformer: Deformer, bc, angle) -> np.ndarray:
    """ARAP with pin angles (cells with modes: the rotated mode solve)."""
    from puppet.deform.rotate import arap_solve_rotated, mode_solve_rotated  # lazy: pins with an angle only

    if pre.arap.mix is not None:
        return mode_solve_rotated(pre.arap, bc, angle, iterations=deformer.iterations, scale=scale_bounds(pre, g, bc))
    return arap_solve_rotated(pre.arap, bc, angle, iterations=deformer.iterations)


def _arap_pose(pre: GroupPre, g: Group, deformer: Deformer, bc, warm) -> np.ndarray:
    """ARAP without pin angles: the default loop, or the accelerated one where the scene
    opts in (rigid cells only), from ``warm`` when given."""
    accelerate = deformer.accelerate == "anderson" and pre.arap.mix is None
    if accelerate and warm is not None:
        U0 = warm
    else:
        U0 = initial_guess(pre, g, bc, deformer.alpha) if deformer.init == "mls" else g.mesh.V
    if accelerate:
        from puppet.deform.anderson import arap_solve_anderson  # lazy: scenes that opt in only

        return arap_solve_anderson(pre.arap, bc, iterations=deformer.iterations, tolerance=deformer.tolerance,
                                   U0=U0)[0]
    return arap_solve(pre.arap, bc, iterations=deformer.iterations, U0=U0, scale=scale_bounds(pre, g, bc))


def scale_bounds(pre: GroupPre, g: Group, bc) -> tuple[float, float] | None:
    """Scale bounds of the group's ``similar`` cells in this pose: within a factor
    :data:`~puppet.deform.modes.SCALE_SPAN` of the scale of the pins' least-squares
    similarity, so a part shrinks or grows evenly with the pins, never balloons between
    them (unbounded similarity cells are conformal maps, which blow up or pinch near
    point handles). None without similar cells."""
    a = pre.arap
    if a is None or a.mix is None or not len(a.modes.similar):
        return None
    s = abs(similarity_fit(g.mesh.V[g.b], bc)[0])
    return s / SCALE_SPAN, s * SCALE_SPAN


def initial_guess(pre: GroupPre, g: Group, bc, alpha: float) -> np.ndarray | None:
    """The MLS initial guess, or None for :func:`arap_solve`'s own (the plain one).

    In mode ``similar`` (garment fitting) the rest mesh is first moved by the
    least-squares similarity of its pins (scale, rotation, shift); a group with hinges
    (link points) is guessed part by part (:func:`puppet.deform.hinge.hinge_guess`)."""
    if not pre.prefit and pre.DH is None:
        return None
    V, b = g.mesh.V, g.b
    if pre.prefit:
        V = apply_similarity(V, *similarity_fit(V[b], bc))
    if pre.DH is None:
        return mls_object_space(V, pre.D, bc, V[b], kind="rigid", alpha=alpha, weights=pre.weights(alpha))
    return hinge_guess(V, pre.D, V[b], bc, g.pin_part, g.mesh.maps, g.hinges, pre.DH, alpha=alpha,
                       weights=pre.hinge_weights(g, alpha))


def preview_group(pre: GroupPre, g: Group, deformer: Deformer, ext: GroupExterior, pose: GroupPose,
                  U0: np.ndarray | None, *, iterations: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A fast approximate solve while a pin is dragged: plain ARAP warm-started from the
    previous frame ``U0`` with a few iterations (no fold relaxation). Methods other than
    ``arap`` without angles, and the first frame, solve exactly."""
    if U0 is None or deformer.method != "arap" or len(g.pins) == 0 or np.any(pose.angle != 0):
        return solve_group(pre, g, deformer, ext, pose)
    U = arap_solve(pre.arap, pose.bc, iterations=iterations, U0=U0, scale=scale_bounds(pre, g, pose.bc))
    return finish(pre, g, deformer, ext, pose, U)


def finish(pre: GroupPre, g: Group, deformer: Deformer, ext: GroupExterior, pose: GroupPose, U: np.ndarray):
    """A solved ``U`` completed: the pins' depth field and the exterior points (which may
    pull the boundary); (U, depth, exterior positions)."""
    if len(g.pins) and np.any(pose.depth):
        depth = depth_field(pre.D, pose.depth, alpha=deformer.alpha, weights=pre.weights(deformer.alpha))
    else:  # no pins, or all at depth 0 (the field is 0 then)
        depth = np.zeros(len(U))
    U, ext_pos = _exterior(g, ext, U, pose.ext_to)
    return U, depth, ext_pos


def _exterior(g: Group, ge: GroupExterior, U: np.ndarray, want: np.ndarray):
    """Exterior points ride along with U; those a pose moves pull the boundary (fine mode)."""
    if ge.frame is None:
        return U, np.zeros((0, 2))
    ride = exterior_positions(U, ge.frame)
    moved = ~np.isnan(want[:, 0])
    target = np.where(moved[:, None], want, ride)
    if moved.any() and not np.array_equal(target, ride):
        U = fine_deform(U, g.mesh.F, g.b, ride, target, mode="points")
    return U, target
