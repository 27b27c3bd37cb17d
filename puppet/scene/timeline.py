"""Keyframe interpolation: a time on the animation -> pin targets (pure math, no GL)."""
from __future__ import annotations

import numpy as np

from puppet.scene.model import Animation


def ease(kind: str, t: float) -> float:
    """Map 0..1 to 0..1: ``linear``, ``smooth`` (smoothstep 3t²-2t³) or ``step`` (hold until the key)."""
    t = min(max(t, 0.0), 1.0)
    if kind == "smooth":
        return t * t * (3.0 - 2.0 * t)
    if kind == "step":
        return 1.0 if t >= 1.0 else 0.0
    return t


def segment_at(anim: Animation, time: float) -> tuple[str, str, float]:
    """The two poses around ``time`` and the eased blend factor from the first to the second.

    Times before the first key give the first pose, after the last key the last pose.
    """
    keys = anim.keys
    if time <= keys[0].time:
        return keys[0].pose, keys[0].pose, 0.0
    for a, b in zip(keys, keys[1:]):
        if time < b.time:
            span = b.time - a.time
            return a.pose, b.pose, ease(b.ease, (time - a.time) / span if span > 0 else 1.0)
    return keys[-1].pose, keys[-1].pose, 0.0


def duration(anim: Animation) -> float:
    return anim.keys[-1].time


def frame_times(anim: Animation, *, fps: float | None = None, start: float | None = None,
                end: float | None = None) -> np.ndarray:
    """Times of every frame from ``start`` to ``end`` inclusive (defaults: whole animation)."""
    fps = fps or anim.fps
    t0 = anim.keys[0].time if start is None else start
    t1 = duration(anim) if end is None else end
    n = int(np.floor((t1 - t0) * fps + 1e-9)) + 1
    return t0 + np.arange(max(n, 1)) / fps
