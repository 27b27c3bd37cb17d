"""Per-pin tracks: the animation's keys as arrays, and the pin state at any time.

A key of a named pose mentions every pin and every exterior point (those the pose does
not name at rest, exterior points riding along) but the ones its ``overrides`` leave out
(``null``), and its overrides' targets replace the pose's; a key of inline ``pins``
mentions only the pins it names. A pin's value at time t comes from the keys that
mention it: held before the first and after the last, in between interpolated with the ease of the later
key. Depth steps (the value of the last key at or before t that sets it) unless the
animation's ``depth`` is ``"interpolate"``. Trajectory-invariant: a state depends only
on the keys and t.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.scene.format.model import Animation, SceneData
from puppet.scene.rig.exterior import GroupExterior
from puppet.scene.time.evaluate import PinState, exterior_names, pose_state, rest_state
from puppet.scene.time.physics import Simulation
from puppet.scene.time.timeline import around, ease


@dataclass
class Tracks:
    """The keys of an animation as arrays (nk keys, k pins, j exterior points)."""

    times: np.ndarray  # (nk,)
    to: np.ndarray  # (nk, k, 2)
    angle: np.ndarray  # (nk, k)
    depth: np.ndarray  # (nk, k)
    ext: np.ndarray  # (nk, j, 2), NaN = rides along
    pin_set: np.ndarray  # (nk, k) bool: key mentions the pin
    ext_set: np.ndarray  # (nk, j) bool
    rest: PinState
    ext_rest: np.ndarray  # (j, 2)
    anim: Animation
    physics: object = None  # the chains' Simulation (puppet.scene.time.physics), None without chains


def build_tracks(data: SceneData, exterior: list[GroupExterior]) -> Tracks:
    """Arrays of every key's values and of which pins it mentions."""
    anim = data.animation
    rest = rest_state(data, exterior)
    k, j = len(rest.to), len(rest.ext_to)
    pin_index = {p.name: i for i, p in enumerate(data.pins)}
    ext_index = {n: i for i, n in enumerate(exterior_names(exterior))}
    states, pin_set, ext_set = [], np.zeros((len(anim.keys), k), bool), np.zeros((len(anim.keys), j), bool)
    for n, key in enumerate(anim.keys):
        if key.pins is None:
            table = dict(data.poses.get(key.pose, {}) if key.pose != "rest" else {})
            pin_set[n] = [p.kind == "interior" for p in data.pins]
            ext_set[n] = True
            for name, t in (key.overrides or {}).items():  # pose plus pin overrides
                if t is not None:
                    table[name] = t
                    continue
                table.pop(name, None)
                if name in ext_index:
                    ext_set[n, ext_index[name]] = False
                elif name in pin_index:
                    pin_set[n, pin_index[name]] = False
        else:
            table = key.pins
            for name in table:
                if name in ext_index:
                    ext_set[n, ext_index[name]] = True
                elif name in pin_index:
                    pin_set[n, pin_index[name]] = True
        states.append(pose_state(data, exterior, table))
    nk = len(anim.keys)
    ext_rest = np.concatenate([ge.rest for ge in exterior]) if exterior else np.zeros((0, 2))
    tr = Tracks(times=np.array([key.time for key in anim.keys], float),
                to=np.array([s.to for s in states]).reshape(nk, k, 2),
                angle=np.array([s.angle for s in states]).reshape(nk, k),
                depth=np.array([s.depth for s in states]).reshape(nk, k),
                ext=np.array([s.ext_to for s in states]).reshape(nk, j, 2),
                pin_set=pin_set, ext_set=ext_set, rest=rest, ext_rest=ext_rest.reshape(j, 2), anim=anim)
    if data.chains:
        tr.physics = Simulation(tr, data.chains, pin_index)
    return tr


def _spans(tr: Tracks, mentions: np.ndarray, time: float):
    """Per column of ``mentions`` (nk, c): (a, b, u) key indices and eased fraction, or
    None for a column no key mentions; columns with the same pattern share the work."""
    out: list = [None] * mentions.shape[1]
    keys = tr.anim.keys
    patterns: dict[bytes, tuple] = {}
    for col in range(mentions.shape[1]):
        pat = mentions[:, col]
        if not pat.any():
            continue
        h = pat.tobytes()
        if h not in patterns:
            idx = np.flatnonzero(pat)
            a, b = around(tr.times[idx], time)
            a, b = int(idx[a]), int(idx[b])
            u = 0.0 if a == b else ease(keys[b].ease, (time - tr.times[a]) / (tr.times[b] - tr.times[a]),
                                        keys[b].curve)
            patterns[h] = (a, b, u)
        out[col] = patterns[h]
    return out


def physics_at(tr: Tracks, time: float) -> tuple[PinState, np.ndarray]:
    """:func:`state_at` with the chains' pins where their secondary motion has them
    (:mod:`puppet.scene.time.physics`), and the indices of the pins it moved off their
    tracks (empty without chains, or while every chain is at rest on its keyed path: the
    state is then :func:`state_at`'s)."""
    s = state_at(tr, time)
    if tr.physics is None:
        return s, np.zeros(0, np.int64)
    sim = tr.physics
    X = sim.positions(time)
    moved = (sim.parent >= 0) & (np.abs(X - s.to[sim.cols]).max(axis=1) > 1e-6)
    s.to[sim.cols[moved]] = X[moved]
    return s, sim.cols[moved]


def state_at(tr: Tracks, time: float) -> PinState:
    """Every pin's target, angle and depth and every exterior point's target at ``time``."""
    s = PinState(to=tr.rest.to.copy(), angle=tr.rest.angle.copy(), depth=tr.rest.depth.copy(),
                 ext_to=tr.rest.ext_to.copy())
    interp_depth = tr.anim.depth == "interpolate"
    for i, span in enumerate(_spans(tr, tr.pin_set, time)):
        if span is None:
            continue
        a, b, u = span
        s.to[i] = (1 - u) * tr.to[a, i] + u * tr.to[b, i]
        s.angle[i] = (1 - u) * tr.angle[a, i] + u * tr.angle[b, i]
        if interp_depth:
            s.depth[i] = (1 - u) * tr.depth[a, i] + u * tr.depth[b, i]
        else:
            s.depth[i] = tr.depth[b, i] if time >= tr.times[b] else tr.depth[a, i]
    for i, span in enumerate(_spans(tr, tr.ext_set, time)):
        if span is None:
            continue
        a, b, u = span
        ea, eb = tr.ext[a, i], tr.ext[b, i]
        if np.isnan(ea[0]) and np.isnan(eb[0]):
            continue
        ea = tr.ext_rest[i] if np.isnan(ea[0]) else ea
        eb = tr.ext_rest[i] if np.isnan(eb[0]) else eb
        s.ext_to[i] = (1 - u) * ea + u * eb
    return s


def mentions(tr: Tracks, pin: str | None, data: SceneData, exterior: list[GroupExterior]) -> np.ndarray:
    """Which keys mention ``pin`` (a pin or exterior point name; every key when None): (nk,) bool."""
    if pin is None:
        return np.ones(len(tr.times), bool)
    names = [p.name for p in data.pins]
    if pin in names:
        return tr.pin_set[:, names.index(pin)]
    ext = exterior_names(exterior)
    if pin in ext:
        return tr.ext_set[:, ext.index(pin)]
    raise KeyError(pin)
