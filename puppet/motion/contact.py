"""Feet on the ground: when a foot joint is down, and its pin held still meanwhile.

A foot is *down* on a frame where its joint is within :data:`HEIGHT` leg lengths of the
ground (the lowest any foot joint comes in the frames used) and moves slower than
:data:`SPEED` leg lengths a second; runs of down frames shorter than :data:`MIN_FRAMES`
are dropped and gaps of one frame filled. While a foot is down its pin's target stays
where it was on the first down frame; at lift-off the offset from the free target fades
out over :data:`BLEND` seconds (smoothstep), so the foot leaves its place without a jump.
"""
from __future__ import annotations

import numpy as np

__all__ = ["BLEND", "down_frames", "hold"]

#: A foot is down within this many leg lengths above the ground...
HEIGHT = 0.08
#: ...and slower than this many leg lengths a second.
SPEED = 0.8
#: Shortest contact kept (frames).
MIN_FRAMES = 3
#: Seconds over which a lifted foot's pin goes from its held place to its free target.
BLEND = 0.2


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[(first, last)]`` of the runs of True in ``mask``."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def down_frames(height: np.ndarray, speed: np.ndarray, leg: float) -> np.ndarray:
    """Frames (bool, (f,)) where a foot at ``height`` above the ground moving at ``speed``
    (both (f,), the motion's units and per second) is down, for a leg ``leg`` long."""
    down = (height <= HEIGHT * leg) & (speed <= SPEED * leg)
    gaps = _runs(~down)
    for a, b in gaps:
        if a > 0 and b < len(down) - 1 and a == b:
            down[a] = True
    for a, b in _runs(down):
        if b - a + 1 < MIN_FRAMES:
            down[a:b + 1] = False
    return down


def hold(target: np.ndarray, down: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``target`` (f, 2) with the pin held still over each run of ``down`` frames and
    blended back to ``target`` over :data:`BLEND` seconds after it."""
    out = np.array(target, np.float64)
    runs = _runs(down)
    for i, (a, b) in enumerate(runs):
        held = out[a].copy()  # where the pin is on touching down (a blend from the last run included)
        out[a:b + 1] = held
        end = runs[i + 1][0] if i + 1 < len(runs) else len(out)
        after = np.arange(b + 1, end)
        if after.size:
            u = np.clip((times[after] - times[b]) / BLEND, 0.0, 1.0)
            w = 1.0 - u * u * (3.0 - 2.0 * u)
            out[after] = target[after] + w[:, None] * (held - target[b])
    return out
