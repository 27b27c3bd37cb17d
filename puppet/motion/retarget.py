"""A BVH motion onto a scene's pins: the keys of an animation that plays it.

1. The frames between ``start`` and ``end`` (seconds) are posed (forward kinematics);
   with ``in_place`` the root's move along the ground is taken out of every joint.
2. They are projected (:mod:`puppet.motion.project`: frontal, sagittal, pca, or by the
   character's facing) and each pin is given a joint (:mod:`puppet.motion.mapping`, or a
   map given).
3. Scale: a leg's length on the character (a pin on a foot to a pin on its hip or thigh
   joint, or the root) over the same joints' distance in the first frame used (3D, so a
   leg seen from the side is not shortened), averaged over the legs found; else the pins'
   height over their joints' projected height.
4. A pin's target is its rest place plus the scaled projected move of its joint since
   the first frame used (``at + s (q_j(t) - q_j(t0))``): the first frame is the
   character's rest pose, and each pin follows its joint's path.
   4b. With ``scale="limbs"``, a pin whose joint has a mapped ancestor joint (the hand's
   chest, the foot's hips) moves with that ancestor's pin, plus its joint's move
   relative to the ancestor scaled by the limb: the pins' distance over the joints'.
5. Feet that are down hold their pins (:mod:`puppet.motion.contact`), unless ``in_place``
   (the ground then moves under them).
6. Keys: the frames a linear in-between reproduces within :data:`TOLERANCE` px are left
   out (:func:`puppet.anim.keys.plan`, linear spans only); the animation plays its
   in-betweens ``linear`` (pins on straight lines between keys, each frame solved as a
   pose), so a pin is where its target is.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.anim.keys import plan
from puppet.errors import SceneError
from puppet.motion import contact
from puppet.motion.bvh import Motion
from puppet.motion.mapping import auto_map
from puppet.motion.names import part_and_side
from puppet.motion.project import PROJECTIONS, axes_of, character_facing, plane

__all__ = ["SCALES", "TOLERANCE", "Retargeted", "animation", "retarget"]

#: Most a pin's in-between may be off its target between two kept keys (px).
TOLERANCE = 0.5
#: Decimals of a written target (px).
DECIMALS = 3
#: How the motion is sized to the character: one scale (``body``), or each limb's own
#: (``limbs``: a T-rex's short arms swing short).
SCALES = ("body", "limbs")
#: Highest frame rate given to the animation (a 120 fps capture exports at 60).
MAX_FPS = 60


@dataclass(frozen=True)
class Retargeted:
    """What :func:`retarget` made: ``times`` (f,) from 0, the ``map`` used, the
    ``projection`` and its ``plane`` (2, 3), the ``scale`` (px per motion unit), the
    pins' ``targets`` {pin: (f, 2)}, their ``free`` targets before feet were held, the
    ``down`` frames of each held foot pin, and ``fps``."""

    times: np.ndarray
    map: dict[str, str]
    projection: str
    plane: np.ndarray
    scale: float
    targets: dict[str, np.ndarray]
    free: dict[str, np.ndarray]
    down: dict[str, np.ndarray]
    fps: float


def _frames(motion: Motion, start: float | None, end: float | None) -> np.ndarray:
    t = motion.times
    lo = 0.0 if start is None else float(start)
    hi = np.inf if end is None else float(end)
    sel = np.flatnonzero((t >= lo - 1e-9) & (t <= hi + 1e-9))
    if sel.size == 0:
        span = f"0-{t[-1]:g} s" if t.size else "no frames"
        when = f"between {lo:g} and {hi:g} s" if end is not None else f"from {lo:g} s on"
        raise SceneError(f"no frame {when} (the motion has {motion.count} frames, {span})", file=motion.file)
    return sel


def _ancestors(motion: Motion, j: int) -> list[int]:
    out = []
    while motion.joints[j].parent >= 0:
        j = motion.joints[j].parent
        out.append(j)
    return out


def _legs(motion: Motion, mapping: dict[str, str], pins: dict[str, np.ndarray], P0: np.ndarray):
    """``[(character length px, motion length)]`` of each foot pin and the pin of its
    nearest hip, thigh or root joint."""
    index = {n: i for i, n in enumerate(motion.names)}
    by_joint = {j: p for p, j in mapping.items()}
    out = []
    for pin, joint in mapping.items():
        j = index[joint]
        if part_and_side(joint)[0] not in ("foot", "toe"):
            continue
        for a in _ancestors(motion, j):
            name = motion.names[a]
            if name in by_joint and (part_and_side(name)[0] in ("hip", "thigh") or motion.joints[a].parent < 0):
                d = float(np.linalg.norm(P0[j] - P0[a]))
                if d > 0:
                    out.append((float(np.linalg.norm(pins[pin] - pins[by_joint[name]])), d))
                break
    return out


def _scale(motion, mapping, pins, P0, Q0) -> tuple[float, float]:
    """``(px per motion unit, the motion's leg length)``."""
    index = {n: i for i, n in enumerate(motion.names)}
    legs = _legs(motion, mapping, pins, P0)
    if legs:
        c, m = np.mean(legs, axis=0)
        if c > 0:
            return float(c / m), float(m)
    names = list(mapping)
    hp = float(np.ptp([pins[n][1] for n in names]))
    hq = float(np.ptp([Q0[index[mapping[n]], 1] for n in names]))
    body = float(np.ptp(P0 @ axes_of(motion.names, P0[None]).up)) or 1.0
    return (hp / hq if hp > 0 and hq > 0 else 1.0), body / 2


def _limb_paths(motion: Motion, mapping: dict[str, str], pins, Q: np.ndarray, P0: np.ndarray,
                s: float) -> dict[str, np.ndarray]:
    """Step 4b: each pin's path from the pin of its nearest mapped ancestor joint, its
    joint's move relative to that joint scaled by their distance on the character over
    their distance in the motion's first frame; a pin with no such ancestor as in step 4."""
    index = {n: i for i, n in enumerate(motion.names)}
    by_joint: dict[str, str] = {}
    for p, j in mapping.items():
        by_joint.setdefault(j, p)
    out: dict[str, np.ndarray] = {}
    for p in sorted(mapping, key=lambda p: len(_ancestors(motion, index[mapping[p]]))):
        j = index[mapping[p]]
        at = np.asarray(pins[p], np.float64)
        a = next((a for a in _ancestors(motion, j) if by_joint.get(motion.names[a], p) != p), None)
        q = by_joint.get(motion.names[a]) if a is not None else None
        if q is None or q not in out:
            out[p] = at + s * (Q[:, j] - Q[0, j])
            continue
        dm, dc = float(np.linalg.norm(P0[j] - P0[a])), float(np.linalg.norm(at - pins[q]))
        k = dc / dm if dm > 0 and dc > 0 else s
        out[p] = out[q] + (at - pins[q]) + k * ((Q[:, j] - Q[:, a]) - (Q[0, j] - Q[0, a]))
    return out


def _down(motion: Motion, mapping: dict[str, str], H: np.ndarray, P: np.ndarray, times: np.ndarray,
          leg: float) -> dict[str, np.ndarray]:
    """Step 5: the down frames of each pin on a foot or toe joint that is ever down
    (``H`` (f, j): the joints' heights, ``P`` (f, j, 3) their places)."""
    index = {n: i for i, n in enumerate(motion.names)}
    feet = [p for p, j in mapping.items() if part_and_side(j)[0] in ("foot", "toe")]
    ground = min((float(H[:, index[mapping[p]]].min()) for p in feet), default=0.0)
    out = {}
    for p in feet:
        j = index[mapping[p]]
        speed = np.linalg.norm(np.gradient(P[:, j], times, axis=0), axis=1)
        d = contact.down_frames(H[:, j] - ground, speed, leg)
        if d.any():
            out[p] = d
    return out


def retarget(motion: Motion, pins: dict[str, np.ndarray], *, mapping: dict[str, str] | None = None,
             projection: str = "auto", in_place: bool = False, start: float | None = None,
             end: float | None = None, scale: str = "body", labels: dict[str, str] | None = None) -> Retargeted:
    """The pins' targets that play ``motion`` on a character whose pins rest at ``pins``
    ``{name: (x, y)}`` (see the module's steps; ``scale`` "limbs": step 4b; ``labels``
    ``{pin: layer name}``, read by the automatic map)."""
    if projection not in PROJECTIONS + ("auto",):
        raise SceneError(f"--projection {projection!r}: one of auto, {', '.join(PROJECTIONS)}")
    if scale not in SCALES:
        raise SceneError(f"--scale {scale!r}: one of {', '.join(SCALES)}")
    sel = _frames(motion, start, end)
    times = motion.times[sel] - motion.times[sel[0]]
    P = motion.positions(sel)
    axes = axes_of(motion.names, P)
    root = next(i for i, j in enumerate(motion.joints) if j.parent < 0)
    if in_place:
        flat = P[:, root] - np.outer(P[:, root] @ axes.up, axes.up)
        P = P - (flat - flat[0])[:, None]
    facing, profile = character_facing(pins)
    kind = projection if projection != "auto" else ("sagittal" if profile else "frontal")
    B = plane(kind, axes, (P - P[:, root:root + 1]).reshape(-1, 3), facing=facing, profile=profile)
    Q = P @ B.T
    if mapping is None:
        mapping = auto_map(pins, motion.names, [Q[0], motion.rest() @ B.T], ends=[j.end for j in motion.joints],
                           root=root, screen_left=float(B[0] @ axes.left), labels=labels)
    s, leg = _scale(motion, mapping, pins, P[0], Q[0])
    index = {n: i for i, n in enumerate(motion.names)}
    if scale == "limbs":
        free = _limb_paths(motion, mapping, pins, Q, P[0], s)
    else:
        free = {p: np.asarray(pins[p], np.float64) + s * (Q[:, index[j]] - Q[0, index[j]])
                for p, j in mapping.items()}
    targets, down = dict(free), {}
    if not in_place and len(times) > 1:
        down = _down(motion, mapping, P @ axes.up, P, times, leg)
        targets.update({p: contact.hold(free[p], d, times) for p, d in down.items()})
    fps = min(1.0 / motion.frame_time, MAX_FPS)
    fps = float(round(fps)) if abs(fps - round(fps)) < 0.01 else round(fps, 3)  # 0.03333 s: 30 fps
    return Retargeted(times, dict(mapping), kind, B, s, targets, free, down, fps)


def animation(r: Retargeted) -> dict:
    """The scene's ``animation``: ``pins`` keys at the frames kept."""
    names = list(r.targets)
    F = np.stack([np.round(r.targets[n], DECIMALS) for n in names], axis=1)
    keys = plan(F, r.times, [], TOLERANCE - 10.0 ** -DECIMALS, curves=False) if len(F) > 1 else []
    frames = [k.frame for k in keys] or [0]
    return {"fps": r.fps, "inbetween": "linear",
            "keys": [{"time": round(float(r.times[f]), 6),
                      "pins": {n: [float(v) for v in F[f, i]] for i, n in enumerate(names)}} for f in frames]}
