"""Curvature of closed contours in Gaussian scale space, and its salient maxima.

Used to place the automatic exterior control points of a layer (garment-retargeting
paper, section 3.3.1; the scale-space curvature is Mokhtarian & Mackworth's "curvature
scale space"). With the closed contour parametrised by arc length ``u`` and resampled
uniformly, its coordinates ``x(u), y(u)`` are circularly convolved with the first and
second derivatives of a Gaussian of standard deviation ``sigma`` and::

    kappa = (x' y'' - y' x'') / (x'^2 + y'^2)^(3/2)

The convolution is done in the Fourier domain: the spectrum of a sampled closed curve
is multiplied by ``(i w)^d exp(-sigma^2 w^2 / 2)`` (``w`` the angular frequency per unit
arc length), which is exactly the circular convolution with the periodised continuous
Gaussian derivative kernel (no truncation of the kernel, no wrap-around seam).

Sign: ``kappa > 0`` where the curve turns in the direction of positive rotation in raw
``(x, y)`` coordinates, i.e. on the convex parts of a ring whose shoelace area
(:func:`puppet.geom.contour.ring_area`) is positive. Maxima are taken of ``|kappa|``,
so they do not depend on the orientation.

Scale: ``sigma = L_scale / beta`` with ``L_scale = L / (2 pi)`` (``L`` the contour
length), the radius of the circle of the same perimeter, so a circle of radius ``r``
is smoothed with ``sigma = r / beta`` whatever its size: the result depends on the
shape only, not on its size or its sampling. Harmonic ``k`` of the contour (``k``
lobes around it) is damped by ``exp(-k^2 / (2 beta^2))``: ``beta = 1`` keeps the
coarsest features only (the two ends of an elongated shape; the corners of a square
just about), ``beta = 2`` the five tips of a star, ``beta >= 4`` its notches too. On
the sample layers (trex parts, horse) ``beta = 1`` gives 2 points, ``beta = 2-4``
3 to 10, ``beta = 8`` 5 to 14.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "contour_length",
    "length_scale",
    "resample_closed",
    "contour_curvature",
    "curvature_maxima",
    "contour_start",
]


def _ring(P) -> np.ndarray:
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2:
        raise ValueError(f"a ring must have shape (n, 2), got {P.shape}")
    if len(P) >= 2 and np.array_equal(P[0], P[-1]):
        P = P[:-1]  # accept an explicitly closed ring
    if len(P) < 3:
        raise ValueError(f"a ring needs at least 3 distinct points, got {len(P)}")
    return P


def _edge_lengths(P: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)


def contour_length(P) -> float:
    """Perimeter of a closed ring (the closing edge included).

    Parameters
    ----------
    P : (n, 2) float
        Ring, not closed (last != first; a repeated first point is dropped).
    """
    return float(_edge_lengths(_ring(P)).sum())


def length_scale(P) -> float:
    """The contour's length scale ``L / (2 pi)``: radius of the circle of equal perimeter.

    ``sigma = length_scale(P) / beta`` in :func:`curvature_maxima`.
    """
    return contour_length(P) / (2.0 * np.pi)


def resample_closed(P, n: int) -> np.ndarray:
    """Uniform arc-length resampling of a closed ring.

    Parameters
    ----------
    P : (m, 2) float
        Ring, not closed (last != first; a repeated first point is dropped).
    n : int
        Number of samples, >= 3.

    Returns
    -------
    Q : (n, 2) float
        ``Q[k]`` is the point at arc length ``k L / n`` from ``P[0]`` along the ring
        in the ring's own direction (``Q[0] == P[0]``), on the closed polyline.
    """
    P = _ring(P)
    n = int(n)
    if n < 3:
        raise ValueError(f"n must be >= 3, got {n}")
    seg = _edge_lengths(P)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    L = s[-1]
    if not L > 0:
        raise ValueError("a ring of zero length cannot be resampled")
    closed = np.vstack([P, P[:1]])
    keep = np.r_[True, seg > 0]  # drop repeated points so arc length is increasing
    s, closed = s[keep], closed[keep]
    t = np.arange(n) * (L / n)
    return np.stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])], axis=1)


def contour_curvature(P, sigma: float) -> np.ndarray:
    """Curvature of a uniformly sampled closed curve at scale ``sigma``.

    Parameters
    ----------
    P : (n, 2) float
        Closed ring sampled uniformly in arc length (see :func:`resample_closed`); the
        spacing is taken as ``L / n``. ``sigma`` should span at least ~2 samples.
    sigma : float
        Standard deviation of the Gaussian, in the units of the arc length (px).
        ``0`` means no smoothing (spectral derivatives).

    Returns
    -------
    kappa : (n,) float
        Signed curvature of the smoothed curve at each sample (see the module doc for
        the sign), in 1/length units. A circle of radius ``r`` gives
        ``exp(sigma^2 / (2 r^2)) / r`` (the smoothed circle shrinks), i.e. ``1/r`` to
        within 0.5% for ``sigma <= r / 10``.
    """
    P = _ring(P)
    if not sigma >= 0:
        raise ValueError(f"sigma must be >= 0, got {sigma}")
    n = len(P)
    h = _edge_lengths(P).sum() / n
    w = 2.0 * np.pi * np.fft.fftfreq(n, d=h)
    Z = np.fft.fft(P[:, 0] + 1j * P[:, 1])  # x + iy: one complex transform for both
    with np.errstate(over="ignore"):  # a huge sigma (a tiny exterior beta): (sigma w)^2 = inf, g = 0, no warning
        g = np.exp(-0.5 * (sigma * w) ** 2)
    d1 = np.fft.ifft(Z * (1j * w) * g)
    d2 = np.fft.ifft(Z * (-(w**2)) * g)
    if n % 2 == 0:
        # the Nyquist term of an odd derivative is not defined for real data: drop it
        nyq = Z[n // 2] * g[n // 2] * 1j * w[n // 2] * (-1.0) ** np.arange(n) / n
        d1 = d1 - nyq
    x1, y1, x2, y2 = d1.real, d1.imag, d2.real, d2.imag
    speed2 = x1 * x1 + y1 * y1
    num = x1 * y2 - y1 * x2
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = num / speed2**1.5
    return np.where(speed2 > 0, kappa, 0.0)


def contour_start(P) -> int:
    """Index of the ring's topmost point (smallest y; leftmost among ties): the start."""
    P = _ring(P)
    return int(np.lexsort((P[:, 0], P[:, 1]))[0])


def curvature_maxima(
    P,
    *,
    beta: float = 1.0,
    min_turn: float = 0.25,
    window: float = 1.0,
    spacing: float | None = None,
    return_curvature: bool = False,
):
    """Salient maxima of ``|curvature|`` of a closed contour, in contour order.

    Parameters
    ----------
    P : (m, 2) float
        Ring (e.g. an outer ring of ``puppet.geom.contour.mask_regions``), any sampling.
    beta : float
        Scale: ``sigma = length_scale(P) / beta``; larger beta -> smaller sigma -> finer
        features -> more points.
    min_turn : float
        Saliency threshold, radians. A corner that turns the tangent by a small angle
        ``theta`` between straight sides has smoothed peak curvature about
        ``theta / (sigma sqrt(2 pi))`` (exactly ``sin(theta) / cos(theta/2)^3`` times
        ``1 / (sigma sqrt(2 pi))``). A maximum is kept when its prominence (its height
        above the higher of the two lowest points separating it from a higher peak,
        within one period) is at least ``min_turn / (sigma sqrt(2 pi))`` (default
        0.25 rad, ~14 degrees). This drops the numerical ripple of a circle and the
        pixel staircase; being relative to sigma, it also drops, at fine scales
        (``sigma`` well under a tenth of their radius), rounded bumps that are no
        corners at that scale.
    window : float
        Non-maximum suppression: kept maxima are at least ``window * sigma`` apart
        along the contour (the stronger one wins). Two corners of the same curve give
        two smoothed maxima only when more than ``2 sigma`` apart anyway.
    spacing : float, optional
        Resampling step along the contour; default ``min(1, sigma / 4)`` of the
        coordinate unit (1 px for canvas contours), with 64 to 65536 samples.
    return_curvature : bool
        Also return the resampled ring and its curvature.

    Returns
    -------
    idx : (j,) int
        Indices into ``P`` of the vertex nearest (along the contour) to each maximum.
        Order: the contour is walked from its topmost point (smallest y, leftmost among
        ties; :func:`contour_start`) in the direction of positive shoelace area, which
        is clockwise as seen on screen (y down): rightward along the top first. The
        same shape therefore gives the same order whichever way its ring is given.
    Q, kappa : (n, 2), (n,) float
        Only with ``return_curvature``: the resampled ring (starting at ``P[idx0]`` in
        that direction) and its curvature.
    """
    from scipy.signal import find_peaks

    P = _ring(P)
    if not beta > 0:
        raise ValueError(f"beta must be > 0, got {beta}")
    m = len(P)
    start = contour_start(P)
    order = np.roll(np.arange(m), -start)  # walk from the start vertex ...
    area = 0.5 * float(np.dot(P[:, 0], np.roll(P[:, 1], -1)) - np.dot(np.roll(P[:, 0], -1), P[:, 1]))
    if area < 0:  # ... in the direction of positive shoelace area
        order = np.r_[order[0], order[1:][::-1]]
    R = P[order]
    seg = _edge_lengths(R)
    L = float(seg.sum())
    sigma = L / (2.0 * np.pi) / beta
    ds = min(1.0, sigma / 4.0) if spacing is None else float(spacing)
    n = int(np.clip(np.ceil(L / ds), 64, 65536))
    Q = resample_closed(R, n)
    kappa = contour_curvature(Q, sigma)
    h = L / n
    a = np.abs(kappa)
    prom = min_turn / (sigma * np.sqrt(2.0 * np.pi))
    dist = max(1.0, window * sigma / h)
    if dist >= n / 2:
        dist = n / 2 - 1  # a period holds at least two peaks' worth of room
    # periodic: find peaks on three periods and keep those of the middle one
    peaks, _ = find_peaks(np.tile(a, 3), prominence=prom, distance=max(1.0, dist), wlen=n + 1)
    peaks = np.sort(peaks[(peaks >= n) & (peaks < 2 * n)] - n)
    # back to vertices of P: nearest along the contour by arc length
    s_vert = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    s_peak = peaks * h
    d = np.abs(s_peak[:, None] - s_vert[None, :])
    d = np.minimum(d, L - d)
    nearest = d.argmin(axis=1)
    # two maxima mapped to the same vertex of a coarse polygon: keep the first
    nearest = nearest[np.r_[True, np.diff(nearest) != 0]] if len(nearest) else nearest
    if len(nearest) > 1 and nearest[-1] == nearest[0]:
        nearest = nearest[:-1]
    idx = order[nearest].astype(np.int64)
    if return_curvature:
        return idx, Q, kappa
    return idx
