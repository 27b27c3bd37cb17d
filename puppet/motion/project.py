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

__all__ = ["PROJECTIONS", "Axes", "axes_of", "plane"]

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
    the screen's left; ``profile``: the offset is over a sixth of the pins' height."""
    if not pins:
        return -1, False
    P = np.array(list(pins.values()), np.float64)
    parts = {n: part_and_side(n)[0] for n in pins}
    hips = [pins[n] for n in pins if parts[n] == "hip"]
    mid = np.mean(hips, axis=0)[0] if hips else float(P[:, 0].mean())
    lead = [pins[n][0] - mid for n in pins if parts[n] == "head"]
    hands = [pins[n][0] - mid for n in pins if parts[n] == "hand"]
    score = (float(np.mean(lead)) if lead else 0.0) + (float(np.mean(hands)) if hands else 0.0)
    height = float(np.ptp(P[:, 1])) or 1.0
    return (1 if score > 0 else -1), abs(score) > height / 6
