"""Keys of the mesh exports (Spine, the web player): which solved frames of a layer to
keep, and the curve between two kept keys, so that interpolating reproduces every frame
within a tolerance.

The model is Spine's deform timeline, which the web player computes the same way:
between keys ``a`` and ``b`` (times ``ta < tb``, values ``Va``, ``Vb``) a frame at time
``t`` is ``Va + p(t) (Vb - Va)``, one fraction ``p`` for every vertex. ``p`` is linear,
``(t - ta) / (tb - ta)``, or given by the key's Bezier ``curve`` ``[cx1, cy1, cx2, cy2]``
(``cx`` in seconds, ``cy`` a fraction: the cubic from ``(ta, 0)`` to ``(tb, 1)``), which
the Spine runtimes read at 9 points (the curve parameter 0.1, 0.2, ... 0.9) and
interpolate linearly between them; :func:`curve_percent` is that polyline.

The frames between two keys are puppet's solved in-betweens (an ARAP solve per frame,
not a blend of the key meshes), so each span is checked: linear first, then the best
curve (least squares over the per-frame best fractions); where neither reproduces every
frame within the tolerance, the span is split at its worst frame and each half is
checked again (:func:`plan`). The scene's own key times are always keys.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: Decimals of a written curve value (the error is measured with the rounded curve).
CURVE_DECIMALS = 5
#: Most frames from one key to the next: a longer span between the scene's keys gets a
#: key every SPAN frames (bounds what a span's measure holds: frames x vertices).
SPAN = 96
#: Curve parameters the runtimes sample between the ends.
_S = np.arange(1, 10) / 10.0


@dataclass(frozen=True)
class Key:
    """One kept frame: its index and the curve to the next key (None: linear)."""

    frame: int
    curve: tuple[float, float, float, float] | None = None


def curve_points(ta: float, tb: float, curve: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the polyline the runtimes use for ``curve`` between ``(ta, 0)`` and
    ``(tb, 1)``: the ends and the cubic Bezier at parameters 0.1 ... 0.9 (11 points)."""
    cx1, cy1, cx2, cy2 = (float(v) for v in curve)
    s = _S
    b1, b2, b3 = 3 * (1 - s) ** 2 * s, 3 * (1 - s) * s * s, s ** 3
    x = (1 - s) ** 3 * ta + b1 * cx1 + b2 * cx2 + b3 * tb
    y = b1 * cy1 + b2 * cy2 + b3
    return np.concatenate([[ta], x, [tb]]), np.concatenate([[0.0], y, [1.0]])


def curve_percent(t: np.ndarray, ta: float, tb: float, curve: Sequence[float] | None) -> np.ndarray:
    """The fraction from key ``a`` to key ``b`` at times ``t`` (ta <= t <= tb): linear
    for ``curve`` None, else the runtimes' polyline of the Bezier."""
    t = np.asarray(t, np.float64)
    if curve is None:
        return (t - ta) / (tb - ta)
    x, y = curve_points(ta, tb, curve)
    return np.interp(t, x, y)


def _errors(F: np.ndarray, a: int, b: int, p: np.ndarray) -> np.ndarray:
    """Largest vertex distance of each frame between ``a`` and ``b`` from its
    interpolation with fractions ``p`` (one per inner frame)."""
    guess = F[a][None] + p[:, None, None] * (F[b] - F[a])[None]
    return np.sqrt(((guess - F[a + 1:b]) ** 2).sum(axis=2)).max(axis=1)


def _fit_curve(T: np.ndarray, s: np.ndarray, ta: float, tb: float) -> tuple[float, float, float, float]:
    """The curve whose polyline best follows fractions ``s`` at times ``T`` (least
    squares), rounded as written. Its handles' times are a third of the span from each
    key, so the polyline's times are evenly spaced and its fractions linear in
    ``cy1, cy2``: the fit is a linear one (exact for puppet's ``smooth`` ease, which is
    this curve with ``cy1 = 0``, ``cy2 = 1``)."""
    h = tb - ta
    cx1, cx2 = ta + h / 3, ta + 2 * h / 3
    # the fraction at T for (cy1, cy2) = (0, 0), (1, 0) and (0, 1): p = p0 + A @ (cy1, cy2)
    p0, p1, p2 = (curve_percent(T, ta, tb, (cx1, a, cx2, b)) for a, b in ((0, 0), (1, 0), (0, 1)))
    A = np.stack([p1 - p0, p2 - p0], axis=1)
    cy = np.linalg.lstsq(A, s - p0, rcond=None)[0]
    return tuple(round(float(v), CURVE_DECIMALS) for v in (cx1, cy[0], cx2, cy[1]))  # type: ignore[return-value]


def fit_span(F: np.ndarray, T: np.ndarray, a: int, b: int, tol: float, *,
             curves: bool = True) -> tuple[bool, Key | None, int]:
    """Whether frames ``a..b`` of ``F`` (frames, vertices, k) at times ``T`` are
    reproduced within ``tol`` by interpolating between ``a`` and ``b`` (linearly, or
    with a curve where ``curves``): ``(True, key a with its curve, -1)``, or ``(False,
    None, the worst inner frame)``."""
    if b - a < 2:
        return True, Key(a), -1
    inner = T[a + 1:b]
    ta, tb = float(T[a]), float(T[b])
    err = _errors(F, a, b, curve_percent(inner, ta, tb, None))
    if err.max() <= tol:
        return True, Key(a), -1
    d = (F[b] - F[a]).astype(np.float64)
    dd = float((d * d).sum())
    if dd > 0 and curves:
        s = ((F[a + 1:b] - F[a][None]) * d[None]).sum(axis=(1, 2)) / dd  # each frame's best fraction
        curve = _fit_curve(inner, s, ta, tb)
        cerr = _errors(F, a, b, curve_percent(inner, ta, tb, curve))
        if cerr.max() <= tol:
            return True, Key(a, curve), -1
        err = np.minimum(err, cerr)
    return False, None, a + 1 + int(np.argmax(err))


def plan(F: np.ndarray, T: np.ndarray, forced: Sequence[int], tol: float, *, curves: bool = True) -> list[Key]:
    """The keys of one layer's frames ``F`` (frames, vertices, k) at times ``T``: every
    frame of ``forced`` (and the first and last), and as few more as keep every frame
    within ``tol`` of its interpolation: a span that does not fit is split at its worst
    frame and each half checked again; every :data:`SPAN` th frame is a key too. ``tol``
    <= 0: every frame, linear; ``curves`` False: linear spans only (no Bezier curve)."""
    m = len(F)
    if tol <= 0:
        return [Key(f) for f in range(m)]
    ends = sorted({0, m - 1, *range(0, m, SPAN), *(f for f in forced if 0 <= f < m)})
    keys: list[Key] = []
    for a, b in zip(ends, ends[1:]):
        todo = [(a, b)]
        while todo:  # the left half first: keys come out in order
            lo, hi = todo.pop()
            ok, key, worst = fit_span(F, T, lo, hi, tol, curves=curves)
            if ok:
                keys.append(key)
            else:
                todo += [(worst, hi), (lo, worst)]
    keys.append(Key(ends[-1]))
    return keys


def scene_frames(anim, start: float, fps: float, count: int) -> list[int]:
    """Frames (0..count-1) that fall on a key time of the scene's animation ``anim``
    (frame i at ``start + i / fps``)."""
    out = []
    for k in anim.keys:
        x = (k.time - start) * fps
        i = round(x)
        if abs(x - i) < 1e-6 and 0 <= i < count:
            out.append(int(i))
    return sorted(set(out))


def span_error(F: np.ndarray, T: np.ndarray, keys: Sequence[Key]) -> float:
    """Largest vertex distance, over every frame, between ``F`` and the interpolation of
    its ``keys`` (a check, for tests and measurements)."""
    worst = 0.0
    for k0, k1 in zip(keys, keys[1:]):
        a, b = k0.frame, k1.frame
        if b - a >= 2:
            p = curve_percent(T[a + 1:b], float(T[a]), float(T[b]), k0.curve)
            worst = max(worst, float(_errors(F, a, b, p).max()))
    return worst if math.isfinite(worst) else math.inf
