"""Keyframe timing: eases, the keys around a time, frame times (pure math, no GL).

A key's ``ease`` shapes the segment that *ends* at that key (as in the scene format):
``linear``, ``smooth`` (smoothstep), ``step`` (hold the earlier key until the later one)
and ``bezier`` with Spine-style control points ``(cx1, cy1, cx2, cy2)``: the cubic
Bezier from (0, 0) to (1, 1) through (cx1, cy1) and (cx2, cy2), read as value (y)
against time (x); cx in [0, 1] keeps it a function of time, cy may overshoot.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from puppet.scene.format.model import Animation


def bezier_ease(curve: Sequence[float], x: float) -> float:
    """y at time fraction ``x`` (0..1) of the Bezier ease ``curve = (cx1, cy1, cx2, cy2)``.

    Solves x(s) = x for the curve parameter s (x(s) is non-decreasing when cx1, cx2 lie
    in [0, 1]) by safeguarded Newton steps, then returns y(s).
    """
    cx1, cy1, cx2, cy2 = (float(v) for v in curve)
    x = min(max(float(x), 0.0), 1.0)
    if x in (0.0, 1.0):
        return x

    def bx(s):
        return 3 * (1 - s) ** 2 * s * cx1 + 3 * (1 - s) * s * s * cx2 + s ** 3

    lo, hi, s = 0.0, 1.0, x
    for _ in range(60):
        f = bx(s) - x
        if abs(f) < 1e-14:
            break
        if f > 0:
            hi = s
        else:
            lo = s
        d = 3 * (1 - s) ** 2 * cx1 + 6 * (1 - s) * s * (cx2 - cx1) + 3 * s * s * (1 - cx2)
        s_new = s - f / d if d > 1e-12 else -1.0
        s = s_new if lo < s_new < hi else 0.5 * (lo + hi)
        if hi - lo < 1e-15:
            break
    return 3 * (1 - s) ** 2 * s * cy1 + 3 * (1 - s) * s * s * cy2 + s ** 3


def ease(kind: str, t: float, curve: Sequence[float] | None = None) -> float:
    """Map 0..1 to the eased fraction: ``linear``, ``smooth`` (3t²-2t³), ``step``
    (0 until t reaches 1) or ``bezier`` (``curve`` = (cx1, cy1, cx2, cy2); may leave 0..1
    between the ends when a cy overshoots)."""
    t = min(max(t, 0.0), 1.0)
    if kind == "smooth":
        return t * t * (3.0 - 2.0 * t)
    if kind == "step":
        return 1.0 if t >= 1.0 else 0.0
    if kind == "bezier":
        if curve is None:
            raise ValueError("the bezier ease needs a curve (cx1, cy1, cx2, cy2)")
        return bezier_ease(curve, t)
    return t


def around(times: Sequence[float], time: float) -> tuple[int, int]:
    """Indices ``(a, b)`` of the keys around ``time`` in sorted ``times``: ``a`` the last
    key at or before it, ``b = a + 1`` the next one; ``(0, 0)`` before the first key and
    ``(n-1, n-1)`` at or after the last (the animation holds there). Of several keys at
    one time the last wins."""
    n = len(times)
    a = int(np.searchsorted(np.asarray(times, float), time, side="right")) - 1
    if a < 0:
        return 0, 0
    if a >= n - 1:
        return n - 1, n - 1
    return a, a + 1


def key_span(anim: Animation, time: float) -> tuple[int, int, float]:
    """The keys around ``time`` over all keys, and the eased fraction from the first to
    the second (with the second key's ease): ``(a, b, u)``; ``a == b`` (u = 0) outside."""
    keys = anim.keys
    a, b = around([k.time for k in keys], time)
    if a == b:
        return a, b, 0.0
    span = keys[b].time - keys[a].time
    return a, b, ease(keys[b].ease, (time - keys[a].time) / span, keys[b].curve)


def segment_at(anim: Animation, time: float) -> tuple[str | None, str | None, float]:
    """The two keys' pose names around ``time`` and the eased blend factor (v1 helper;
    ``None`` for a key of inline pins). Before the first key the first pose, after the
    last key the last pose."""
    a, b, u = key_span(anim, time)
    return anim.keys[a].pose, anim.keys[b].pose, u


def duration(anim: Animation) -> float:
    """Time of the last key, seconds."""
    return anim.keys[-1].time


def frame_count(t0: float, t1: float, fps: float) -> int:
    """Frames from ``t0`` to ``t1`` inclusive at ``fps`` (frame i at ``t0 + i / fps``; a
    span short of a whole number of frames by rounding only, ``0.3 * 10``, counts it); at
    least 1. The one count of the export, the app's timeline and :func:`frame_times`."""
    return max(int(math.floor((t1 - t0) * fps + 1e-9)) + 1, 1)


def frame_times(anim: Animation, *, fps: float | None = None, start: float | None = None,
                end: float | None = None) -> np.ndarray:
    """Times of every frame from ``start`` to ``end`` inclusive (defaults: whole animation)."""
    fps = fps or anim.fps
    t0 = anim.keys[0].time if start is None else start
    t1 = duration(anim) if end is None else end
    return t0 + np.arange(frame_count(t0, t1, fps)) / fps
