"""Secondary motion: chains of pins that follow the animation through damped springs
(the scene's ``physics.chains``, :mod:`puppet.scene.format.physics`).

In a chain ``p0, p1, ..., pn`` the anchor ``p0`` is where the animation puts it. Each
later pin ``pi`` is pulled towards its *goal*, its animated place seen from its parent's
simulated place, ``g_i = x_(i-1) + (a_i - a_(i-1))`` (``a`` the animated positions), by a
damped spring of natural frequency ``f`` (Hz, ``w = 2 pi f``) and damping ratio ``z``,
plus gravity ``G`` (px/s^2 along +y)::

    x_i'' = w^2 (g_i - x_i) + 2 z w (g_i' - x_i') + (0, G)

then kept at its animated distance from its parent (a sleeve or a tail swings, it does
not stretch). So a pin lags and overshoots where the animation turns, more at a chain's
end than near its anchor, and settles on the animated pose once the motion stops (with
``G = 0``; gravity makes it hang).

The state is stepped at :data:`RATE` steps a second from t = 0 (every pin at its
animated place, at rest), by backward Euler in the spring (unconditionally stable and
dissipative: the energy only falls when ``z > 0``). A time between two steps is the
linear blend of the two. The steps are made once, in order, and kept, so the same time
gives the same positions whatever the frame rate or the order the frames are asked in.
"""
from __future__ import annotations

import numpy as np

from puppet.scene.format.model import Chain
from puppet.scene.time.timeline import bezier_ease

#: Internal steps a second.
RATE = 240
#: Steps made at once (the animated positions of a block come in one vectorised call).
BLOCK = 512


class Simulation:
    """The chains of a scene, stepped lazily from t = 0.

    Parameters
    ----------
    tracks : the animation's :class:`~puppet.scene.time.tracks.Tracks`.
    chains : the scene's chains. pin_index : pin name -> index in the scene's pins.
    """

    def __init__(self, tracks, chains: list[Chain], pin_index: dict[str, int]):
        self.tracks = tracks
        # level-major order, longest chains first: level d holds the d-th pin of the n_d
        # chains that long, right after level d - 1, whose first n_d pins are their parents
        chains = sorted(chains, key=lambda ch: -len(ch.pins))
        cols, parent, w, z, g, self._slices = [], [], [], [], [], []
        for d in range(len(chains[0].pins) if chains else 0):
            start = len(cols)
            for c, ch in enumerate(ch for ch in chains if len(ch.pins) > d):
                parent.append(-1 if d == 0 else self._slices[-1][0] + c)
                cols.append(pin_index[ch.pins[d]])
                w.append(2.0 * np.pi * ch.frequency)
                z.append(ch.damping)
                g.append(ch.gravity)
            self._slices.append((start, len(cols)))
        self.cols = np.array(cols, np.int64)  # the chains' pins, level by level
        self.parent = np.array(parent, np.int64)  # index into cols, -1 for an anchor
        w, z = np.array(w), np.array(z)
        gravity = np.stack([np.zeros(len(g)), np.array(g, float)], axis=1)
        dt = 1.0 / RATE
        self._levels = []  # per level after the first: its slice, its parents' slice, its constants
        for (s0, s1), (p0, _) in zip(self._slices[1:], self._slices):
            sl, ps = slice(s0, s1), slice(p0, p0 + s1 - s0)
            self._levels.append((sl, ps, (w[sl] ** 2)[:, None], (2.0 * z[sl] * w[sl])[:, None],
                                 (1.0 + 2.0 * z[sl] * w[sl] * dt + (w[sl] * dt) ** 2)[:, None], gravity[sl]))
        self._n0 = self._slices[0][1] if self._slices else 0  # the anchors: the first level
        a0 = chain_paths(tracks, self.cols, self.parent, np.zeros(1))[0]
        self.X = [a0]  # positions at step k (k / RATE seconds)
        self._x, self._v, self._a = a0.copy(), np.zeros_like(a0), a0
        self._goal = a0.copy()

    def positions(self, time: float) -> np.ndarray:
        """(len(cols), 2) positions of the chains' pins at ``time`` (seconds >= 0)."""
        s = max(float(time), 0.0) * RATE
        k = int(np.floor(s))
        while len(self.X) <= k + 1:
            self._steps()
        u = s - k
        return self.X[k] if u == 0.0 else (1.0 - u) * self.X[k] + u * self.X[k + 1]

    def _steps(self) -> None:
        k0 = len(self.X)
        times = (k0 + np.arange(BLOCK)) / RATE
        for a in chain_paths(self.tracks, self.cols, self.parent, times):
            self._step(a)

    def _step(self, a: np.ndarray) -> None:
        dt = 1.0 / RATE
        x, v, goal = self._x.copy(), self._v.copy(), self._goal.copy()
        n0 = self._n0
        x[:n0], v[:n0] = a[:n0], (a[:n0] - self._a[:n0]) * RATE
        for sl, ps, w2, zw2, denom, grav in self._levels:  # parents before their children
            rel = a[sl] - a[ps]
            g = x[ps] + rel
            # backward Euler: v' = v + dt (w^2 (g - x - dt v') + 2 z w (g' - v') + G)
            vn = (v[sl] + dt * (w2 * (g - x[sl]) + zw2 * (g - self._goal[sl]) * RATE + grav)) / denom
            arm = x[sl] + dt * vn - x[ps]  # kept at its animated distance from the parent
            r = np.sqrt((arm * arm).sum(axis=1))[:, None]
            length = np.sqrt((rel * rel).sum(axis=1))[:, None]
            xn = np.where(r > 1e-12, x[ps] + arm * (length / np.maximum(r, 1e-12)), g)
            v[sl] = (xn - x[sl]) * RATE
            x[sl] = xn
            goal[sl] = g
        self._x, self._v, self._a, self._goal = x, v, a, goal
        self.X.append(x)


def chain_paths(tracks, cols: np.ndarray, parent: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(len(times), len(cols), 2) animated places of the chains' pins: a pin some key
    mentions follows its track; one no key mentions is carried by its chain's anchor, moved
    and turned with it (``a_0 + R(angle_0) (rest_i - rest_0)``, the angle counter-clockwise on
    screen), as a sleeve follows its arm."""
    out = pin_paths(tracks, cols, times)
    root = np.arange(len(cols))
    while (parent[root] >= 0).any():
        root = np.where(parent[root] >= 0, parent[root], root)
    carried = [j for j, c in enumerate(cols) if parent[j] >= 0 and not tracks.pin_set[:, c].any()]
    if carried:
        anchors = np.unique(root[carried])
        angle = dict(zip(anchors, pin_paths(tracks, cols[anchors], times, tracks.angle)[..., 0].T))
        rest = tracks.rest.to
        for j in carried:
            r = root[j]
            th = -np.radians(angle[r])  # pin angles turn counter-clockwise on screen (y down)
            d = rest[cols[j]] - rest[cols[r]]
            out[:, j, 0] = out[:, r, 0] + np.cos(th) * d[0] - np.sin(th) * d[1]
            out[:, j, 1] = out[:, r, 1] + np.sin(th) * d[0] + np.cos(th) * d[1]
    return out


def pin_paths(tracks, cols: np.ndarray, times: np.ndarray, values: np.ndarray | None = None) -> np.ndarray:
    """(len(times), len(cols), 2) animated targets of the pins ``cols`` at ``times``: the
    values :func:`~puppet.scene.time.tracks.state_at` gives, vectorised over times.
    ``values``: another (nk, k) track of the keys (the angles: then (len(times), len(cols), 1))."""
    tr = tracks
    times = np.asarray(times, float)
    vals = tr.to if values is None else values[..., None]
    base = tr.rest.to if values is None else tr.rest.angle[:, None]
    out = np.broadcast_to(base[cols], (len(times), len(cols), vals.shape[-1])).copy()
    keys = tr.anim.keys
    for j, c in enumerate(cols):
        idx = np.flatnonzero(tr.pin_set[:, c])
        if not len(idx):
            continue
        kt = tr.times[idx]
        a = np.searchsorted(kt, times, side="right") - 1
        b = np.clip(a + 1, 0, len(idx) - 1)
        a = np.clip(a, 0, len(idx) - 1)
        b = np.where(times < kt[0], 0, b)  # held before the first key and after the last
        span = kt[b] - kt[a]
        frac = np.where(b > a, (times - kt[a]) / np.where(span > 0, span, 1.0), 0.0)
        u = np.zeros(len(times))
        for kb in np.unique(b[b > a]):
            sel = (b == kb) & (b > a)
            key = keys[idx[kb]]
            u[sel] = _eases(key.ease, frac[sel], key.curve)
        A, B = vals[idx[a], c], vals[idx[b], c]
        out[:, j] = (1.0 - u)[:, None] * A + u[:, None] * B
    return out


def _eases(kind: str, t: np.ndarray, curve) -> np.ndarray:
    """:func:`~puppet.scene.time.timeline.ease` of many fractions."""
    t = np.clip(t, 0.0, 1.0)
    if kind == "smooth":
        return t * t * (3.0 - 2.0 * t)
    if kind == "step":
        return (t >= 1.0).astype(float)
    if kind == "bezier":
        return np.array([bezier_ease(curve, x) for x in t])
    return t
