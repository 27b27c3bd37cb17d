"""Record mode (After Effects' Puppet Sketch): a pin's dragged path, sampled in real time,
turned into a few keys.

:func:`simplify_path` keeps the fewest samples such that replaying the kept ones with
linear interpolation *in time* stays within a tolerance of every recorded sample: the
Douglas-Peucker split on the synchronised distance (the distance between a sample and
where the straight segment puts the pin *at that sample's time*; Meratnia & de By 2004,
"top-down time-ratio"). Unlike Douglas-Peucker on the path's shape alone, a pause or a
change of speed along a straight line is kept, so the keys replay the timing too.

Pure numpy; the app's record tool (:mod:`puppet.app.model.timeline`) feeds it.
"""
from __future__ import annotations

import numpy as np

#: record speeds offered (timeline seconds per second of dragging)
SPEEDS = (0.5, 1.0, 2.0)


def synchronised_errors(t: np.ndarray, p: np.ndarray, a: int, b: int) -> np.ndarray:
    """Distances of samples ``a..b`` from the segment a->b travelled linearly in time.

    Parameters
    ----------
    t : (n,) float
        Sample times, non-decreasing.
    p : (n, 2) float
        Sample positions.
    a, b : int
        First and last sample of the segment (``a < b``).

    Returns
    -------
    (b - a + 1,) float
        Distance of each sample from where the segment is at its time (0 at both ends).
    """
    span = t[b] - t[a]
    u = (t[a:b + 1] - t[a]) / span if span > 0 else np.zeros(b - a + 1)
    on = p[a] + u[:, None] * (p[b] - p[a])
    return np.hypot(*(p[a:b + 1] - on).T)


def simplify_path(t, p, tolerance: float) -> np.ndarray:
    """Indices of the samples to keep as keys.

    Parameters
    ----------
    t : (n,) array_like
        Sample times in seconds, non-decreasing.
    p : (n, 2) array_like
        Positions (canvas pixels) at those times.
    tolerance : float
        Largest distance, in pixels, between a recorded sample and the replay of the kept
        samples (linear in time) at that sample's time.

    Returns
    -------
    (k,) int
        Increasing indices into the samples, always the first and the last (one index for
        a single sample). Replaying them is within ``tolerance`` of every sample.
    """
    t = np.asarray(t, float)
    p = np.asarray(p, float).reshape(-1, 2)
    n = len(t)
    if n != len(p):
        raise ValueError(f"{n} times but {len(p)} positions")
    if n <= 2:
        return np.arange(n)
    if np.any(np.diff(t) < 0):
        raise ValueError("sample times must not decrease")
    tol = max(float(tolerance), 0.0)
    keep = np.zeros(n, bool)
    keep[0] = keep[-1] = True
    stack = [(0, n - 1)]
    while stack:  # iterative split: a long recording must not hit the recursion limit
        a, b = stack.pop()
        if b - a < 2:
            continue
        err = synchronised_errors(t, p, a, b)
        k = int(np.argmax(err))
        if err[k] > tol:
            m = a + k
            keep[m] = True
            stack += [(a, m), (m, b)]
    return np.flatnonzero(keep)


def replay(t_keys, p_keys, t) -> np.ndarray:
    """Positions (m, 2) at times ``t`` (m,) from keys linear in time (held outside them)."""
    t_keys = np.asarray(t_keys, float)
    p_keys = np.asarray(p_keys, float).reshape(-1, 2)
    t = np.asarray(t, float)
    return np.stack([np.interp(t, t_keys, p_keys[:, 0]), np.interp(t, t_keys, p_keys[:, 1])], axis=1)


def dedupe_times(t, p, min_gap: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Samples with strictly increasing times at least ``min_gap`` apart (a later sample
    closer than that to the one kept before replaces it), so no two keys share a time."""
    t = np.asarray(t, float)
    p = np.asarray(p, float).reshape(-1, 2)
    out_t: list[float] = []
    out_p: list[np.ndarray] = []
    for ti, pi in zip(t, p):
        if out_t and ti - out_t[-1] < min_gap:
            if len(out_t) > 1:  # keep the first sample (where the drag started) as it is
                out_p[-1] = pi
            continue
        out_t.append(float(ti))
        out_p.append(pi)
    return np.asarray(out_t), np.asarray(out_p).reshape(-1, 2)


class Recording:
    """Samples of one record gesture: (timeline time, pin positions) as the pointer moves.

    ``start`` is the playhead when recording began; ``speed`` how many timeline seconds
    pass per second of real time (0.5: slow motion while recording, twice as fast on
    playback). Times are taken from the caller's clock (``now``), so tests drive it.
    """

    def __init__(self, start: float, speed: float, now: float):
        self.start, self.speed, self.t0 = float(start), float(speed), float(now)
        self.times: list[float] = []
        self.points: dict[str, list[tuple[float, float]]] = {}

    def time(self, now: float) -> float:
        """The timeline time at real time ``now``."""
        return self.start + max(now - self.t0, 0.0) * self.speed

    def add(self, now: float, positions: dict) -> float:
        """Note ``positions`` ({pin: (x, y)}) at real time ``now``; returns its timeline time."""
        t = self.time(now)
        self.times.append(t)
        for name, xy in positions.items():
            self.points.setdefault(name, []).append((float(xy[0]), float(xy[1])))
        return t

    def keys(self, tolerance: float, ndigits: int = 4) -> dict[float, dict[str, list[float]]]:
        """The simplified keys: {time: {pin: [x, y]}} (times rounded to ``ndigits``)."""
        out: dict[float, dict[str, list[float]]] = {}
        for name, pts in self.points.items():
            t, p = dedupe_times(self.times[:len(pts)], pts, 10.0 ** -ndigits * 2)
            for i in simplify_path(t, p, tolerance):
                key = out.setdefault(round(float(t[i]), ndigits), {})
                key[name] = [round(float(p[i, 0]), 2), round(float(p[i, 1]), 2)]
        return dict(sorted(out.items()))
