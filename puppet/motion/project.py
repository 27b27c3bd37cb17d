"""From 3D joints to the picture: the performer's axes, the projection plane, the facing.

The axes come from the motion itself (over the frames used): *up* from the feet to the
head, snapped to the nearest axis of the file (BVH files are Y-up or Z-up); *left* from
the right side's joints to the left side's (by their names), made square to up; *forward*
``= left x up``. The screen's y axis points down.

- ``frontal``: the performer seen from the front: screen x along *left* (a performer's
  left hand is on the screen's right, as a character facing the viewer has it).
- ``sagittal``: seen from the side: screen x along *forward*, or against it when the
  character faces the screen's left.
- ``pca``: the plane of largest variance of the joints relative to the root (its normal
  is the direction of least variance), turned so that up stays up and x goes the way of
  the frontal or sagittal x it is nearer.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.motion.names import part_and_side

__all__ = ["PROJECTIONS", "Axes", "axes_of", "character_facing", "parts_by_place", "plane"]

PROJECTIONS = ("frontal", "sagittal", "pca")


@dataclass(frozen=True)
class Axes:
    """Unit 3-vectors of the performer: ``up``, ``left``, ``forward``."""

    up: np.ndarray
    left: np.ndarray
    forward: np.ndarray


def _mean_of(P: np.ndarray, idx: list[int]) -> np.ndarray | None:
    return P[:, idx].mean(axis=(0, 1)) if idx else None


def axes_of(names: list[str], P: np.ndarray) -> Axes:
    """The performer's axes from joint ``names`` and positions ``P`` (frames, joints, 3)."""
    parts = [part_and_side(n) for n in names]
    pick = lambda want, side=None: [i for i, (p, s) in enumerate(parts) if p in want and (side is None or s == side)]  # noqa: E731
    up = np.array([0.0, 1.0, 0.0])
    head, feet = _mean_of(P, pick({"head", "neck"})), _mean_of(P, pick({"foot", "toe"}))
    if head is not None and feet is not None and np.linalg.norm(head - feet) > 0:
        d = head - feet
        k = int(np.argmax(np.abs(d)))
        up = np.zeros(3)
        up[k] = np.sign(d[k])
    sides = {"thigh", "knee", "foot", "shoulder", "elbow", "hand", "hip"}
    lt, rt = _mean_of(P, pick(sides, "left")), _mean_of(P, pick(sides, "right"))
    left = None
    if lt is not None and rt is not None:
        left = lt - rt
        left = left - (left @ up) * up
    if left is None or np.linalg.norm(left) < 1e-9:
        left = np.roll(up, -1)  # Y up: X; Z up: X
    left = left / np.linalg.norm(left)
    return Axes(up, left, np.cross(left, up))


def plane(kind: str, axes: Axes, relative: np.ndarray, *, facing: int, profile: bool) -> np.ndarray:
    """The (2, 3) projection of ``kind``: rows are the screen's x and y as 3-vectors.

    ``relative`` (n, 3): joint positions relative to the root (for ``pca``);
    ``facing``: -1 when the character faces the screen's left, 1 right;
    ``profile``: whether the character is drawn from the side (which x a ``pca`` plane takes)."""
    down = -axes.up
    if kind == "frontal":
        return np.stack([axes.left, down])
    if kind == "sagittal":
        return np.stack([facing * axes.forward, down])
    X = relative - relative.mean(axis=0)
    w, V = np.linalg.eigh(X.T @ X)
    normal = V[:, 0]
    upin = axes.up - (axes.up @ normal) * normal
    if np.linalg.norm(upin) < 1e-6:  # a motion flat on the ground: nothing to see from above
        return np.stack([axes.left, down])
    upin /= np.linalg.norm(upin)
    x = np.cross(upin, normal)
    ref = facing * axes.forward if profile else axes.left
    return np.stack([x if x @ ref >= 0 else -x, -upin])


def character_facing(pins: dict[str, np.ndarray]) -> tuple[int, bool]:
    """``(facing, profile)`` of a character from its pins' names and places: where its
    head and hands are against its hips (or the pins' middle), along x. ``facing`` -1:
    the screen's left; ``profile``: the offset is over a sixth of the pins' height.
    Where no pin's name says head or hand (``p0..p8``), the parts of the pins whose names
    say nothing are found by :func:`parts_by_place`; such a character not found in
    profile is ``(-1, False)``, as it was before parts were found by place."""
    if not pins:
        return -1, False
    parts = {n: part_and_side(n)[0] for n in pins}
    if any(p in ("head", "hand") for p in parts.values()):
        return _facing(pins, parts)
    guessed = parts_by_place(pins)
    facing, profile = _facing(pins, {n: parts[n] or guessed[n] for n in pins})
    return (facing, True) if profile else (-1, False)


def _facing(pins: dict[str, np.ndarray], parts: dict[str, str | None]) -> tuple[int, bool]:
    P = np.array(list(pins.values()), np.float64)
    hips = [pins[n] for n in pins if parts[n] == "hip"]
    mid = np.mean(hips, axis=0)[0] if hips else float(P[:, 0].mean())
    lead = [pins[n][0] - mid for n in pins if parts[n] == "head"]
    hands = [pins[n][0] - mid for n in pins if parts[n] == "hand"]
    score = (float(np.mean(lead)) if lead else 0.0) + (float(np.mean(hands)) if hands else 0.0)
    height = float(np.ptp(P[:, 1])) or 1.0
    return (1 if score > 0 else -1), abs(score) > height / 6


#: Shares of the pins' height (``h``) and of the hip-to-head line (``t``) that
#: :func:`parts_by_place` reads places by.
FOOT_BAND = 0.6  # a foot is below this much of h from the top
FOOT_GROUND = 0.1  # ... and any pin within this much of h of the lowest is a foot too (four hooves)
HIP_BAND = 0.25  # the hip is within this much of h (along x) of the feet's middle
CHEST_AT, CHEST_BAND = 0.45, 0.15  # the chest: t nearest this, within this much of h of the line
HEAD_FROM, HEAD_NEAR = 0.75, 0.3  # another head pin: t over this, within this much of h of the head
TAIL_OUT = 0.4  # a tail: this much of h behind the hip (away from the head), t under 0


def parts_by_place(pins: dict[str, np.ndarray]) -> dict[str, str | None]:
    """A part for every pin from its place among the others (y down), whatever its name:
    the feet are the two lowest pins below :data:`FOOT_BAND` of the height and any within
    :data:`FOOT_GROUND` of the lowest (four hooves); the
    head the highest other; the hip the lowest other within :data:`HIP_BAND` heights
    (along x) of the feet's middle; on the line from the hip to the head (``t`` 0 to 1),
    the chest the pin nearest ``t`` = :data:`CHEST_AT` within :data:`CHEST_BAND` heights of
    it; a head (a jaw) any pin past ``t`` = :data:`HEAD_FROM` near the head; a tail a pin
    below ``t`` = 0, over :data:`TAIL_OUT` heights behind the hip on the side away from
    the head; the hands the two others farthest
    from the line. Others, and every pin of fewer than four, get None."""
    names = list(pins)
    out: dict[str, str | None] = dict.fromkeys(names)
    P = np.array([pins[n] for n in names], np.float64).reshape(-1, 2)
    h = float(np.ptp(P[:, 1])) if len(P) else 0.0
    if len(P) < 4 or h <= 0:
        return out
    y = (P[:, 1] - P[:, 1].min()) / h
    low = np.argsort(-y, kind="stable")
    feet = [int(i) for k, i in enumerate(low) if y[i] >= 1 - FOOT_GROUND or (k < 2 and y[i] >= FOOT_BAND)]
    rest = [i for i in range(len(P)) if i not in feet]
    head = min(rest, key=lambda i: P[i, 1])
    rest.remove(head)
    mid = P[feet, 0].mean() if feet else float(np.median(P[:, 0]))
    near = [i for i in rest if abs(P[i, 0] - mid) <= HIP_BAND * h]
    out.update({names[i]: "foot" for i in feet})
    out[names[head]] = "head"
    if not near:
        return out
    hip = max(near, key=lambda i: P[i, 1])
    rest.remove(hip)
    out[names[hip]] = "hip"
    d = P[head] - P[hip]
    rel = P - P[hip]
    t = rel @ d / max(float(d @ d), 1e-12)
    off = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / max(float(np.linalg.norm(d)), 1e-12) / h
    chest = [i for i in rest if 0.2 <= t[i] <= 0.85 and off[i] <= CHEST_BAND]
    if chest:
        c = min(chest, key=lambda i: abs(t[i] - CHEST_AT) + off[i])
        rest.remove(c)
        out[names[c]] = "chest"
    hands = []
    for i in rest:
        if t[i] > HEAD_FROM and np.linalg.norm(P[i] - P[head]) <= HEAD_NEAR * h:
            out[names[i]] = "head"
        elif t[i] < 0 and rel[i, 0] * d[0] < 0 and abs(rel[i, 0]) > TAIL_OUT * h:
            out[names[i]] = "tail"
        else:
            hands.append(i)
    for i in sorted(hands, key=lambda i: -off[i])[:2]:
        out[names[i]] = "hand"
    return out
