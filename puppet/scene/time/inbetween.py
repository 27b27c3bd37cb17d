"""Frames of an animation: the meshes of every layer at a time, by the animation's
``inbetween`` mode.

``linear``: each frame's pin state (per-pin tracks, :mod:`puppet.scene.time.tracks`) is solved
like a pose. ``rigid``: the meshes solved at the two key times around t (each exactly as
that pose would be) are interpolated as rigidly as possible
(:mod:`puppet.deform.interp`) with the later key's ease; pins that stay put between the
two keys are held, the others move with the shape; triangles the least-squares fit
leaves folded are relaxed as in a solved pose (``deformer.relax_foldovers``). At key times both modes give the key's
solved mesh exactly (but for groups with a physics chain, solved from each frame's pins).
The pin depth follows its track in both modes. A caged layer's
``rigid`` in-between is its two key cages blended vertex by vertex (its mesh is the cage
map of that cage, so it moves on straight lines between the keys' meshes).
"""
from __future__ import annotations

import numpy as np

from puppet.deform.boundary import exterior_positions
from puppet.deform.depth import depth_field
from puppet.deform.interp import interp_pair, interp_precompute, interp_solve
from puppet.deform.relax import relax_foldovers
from puppet.scene.rig.cache import fingerprint
from puppet.scene.rig.core import Built, LayerResult, Rig
from puppet.scene.time.timeline import key_span
from puppet.scene.time.tracks import Tracks, physics_at, state_at

#: A pin moving less than this (canvas pixels) between two keys is held in the in-between.
STILL = 1e-9


def layers_at(rig: Rig, built: Built, tracks: Tracks, time: float) -> list[LayerResult]:
    """Per-layer results at ``time`` (seconds) on the animation. Groups holding a pin of a
    physics chain (:mod:`puppet.scene.time.physics`) are solved from that frame's pins in
    either mode (their pins leave the keys' paths)."""
    state, swinging = physics_at(tracks, time)
    if tracks.anim.inbetween == "linear":
        return rig.evaluate(built, state)
    live = {gi for gi, g in enumerate(built.groups) if np.isin(g.pins, swinging).any()}
    a, b, u = key_span(tracks.anim, time)
    if a == b or u == 0.0 or u == 1.0:  # exactly the key's solved meshes
        key = state_at(tracks, tracks.times[b if u == 1.0 else a])
        solved = {}
        for gi in range(len(built.groups)):
            U, _, ext = rig.solve(built, gi, state if gi in live else key)
            solved[gi] = (U, _depth(built, gi, state.depth, U), ext)
        return rig.evaluate(built, state, solved=solved)
    sa, sb = state_at(tracks, tracks.times[a]), state_at(tracks, tracks.times[b])
    solved = {}
    for gi in range(len(built.groups)):
        if gi in live:
            U, _, ext = rig.solve(built, gi, state)
            solved[gi] = (U, _depth(built, gi, state.depth, U), ext)
            continue
        if built.cages and built.cages[gi]:  # a caged layer: its cage in between, vertex by vertex
            C = (1.0 - u) * rig.solve(built, gi, sa)[2] + u * rig.solve(built, gi, sb)[2]
            U = built.cages[gi].cmap.apply(C)
            solved[gi] = (U, _depth(built, gi, state.depth, U), C)
            continue
        solved[gi] = rigid_group(rig, built, gi, rig.solve(built, gi, sa)[0], rig.solve(built, gi, sb)[0],
                                 u, state.depth)
    return rig.evaluate(built, state, solved=solved)


def _depth(built: Built, gi: int, depth: np.ndarray, U: np.ndarray) -> np.ndarray:
    """Pin-depth field (n,) of group ``gi`` for the scene pins' depths ``depth`` (k,)."""
    g = built.groups[gi]
    if not len(g.pins):
        return np.zeros(len(U))
    return depth_field(built.pre[gi].D, depth[g.pins], alpha=built.data.deformer.alpha)


def rigid_group(rig: Rig, built: Built, gi: int, UA: np.ndarray, UB: np.ndarray, u: float,
                depth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(U, depth, exterior positions) of group ``gi`` between key meshes ``UA`` and ``UB``
    (n, 2) at eased fraction ``u``; ``depth`` (k,) are the scene pins' depths now."""
    g, pre, ge = built.groups[gi], built.pre[gi], built.exterior[gi]
    if np.array_equal(UA, UB):
        U = UA
    else:
        moved = np.linalg.norm(UA[g.b] - UB[g.b], axis=1) if len(g.b) else np.zeros(0)
        fixed = np.asarray(g.b, np.int64)[moved <= STILL]
        data = rig.memo.get("inbetween", fingerprint("interp", built.pre_keys[gi], fixed),
                            lambda: interp_precompute(g.mesh.V, g.mesh.F, fixed,
                                                      couple=(g.couple, g.kappa) if len(g.couple) else None))
        pair = rig.memo.get("keypair", fingerprint(built.pre_keys[gi], UA, UB), lambda: interp_pair(data, UA, UB))
        U = interp_solve(data, pair, u, anchors=g.b)
        if built.data.deformer.relax_foldovers and pre.arap is not None and len(g.b):
            U = relax_foldovers(pre.arap, U, U[g.b])  # as solved poses are relaxed
    d = _depth(built, gi, depth, U)
    ext = exterior_positions(U, ge.frame) if ge.frame is not None else np.zeros((0, 2))
    return U, d, ext
