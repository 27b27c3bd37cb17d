"""Refine a carried joint by aligning its neighbourhood in the reference frame to the current frame.

Key points on flat-coloured cartoons are sparse: a joint at a tail tip or a hand may have none
nearby, and the triangle or local fit that carries it mixes in motion of other parts. The
reference frame's neighbourhood of the joint (a square of ``2 r + 1`` pixels) is first warped by
the carrying map (so it looks as predicted on the current frame), then aligned to the current
frame by ECC (Evangelidis and Psarakis 2008, ``cv2.findTransformECC``) with a rigid motion;
the joint moves with the correction. A flat neighbourhood (no edges) or a poor correlation
keeps the carried position.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass
class Refined:
    """Result of :func:`refine`.

    Attributes
    ----------
    xy : (2,) float array
        The refined position (the predicted one when ``ok`` is False).
    rho : float
        ECC correlation coefficient of the aligned neighbourhoods (0 when it failed).
    affine : (2, 3) float array
        Reference frame -> current frame map around the joint, correction included.
    ok : bool
        Whether the alignment converged with ``rho >= min_rho`` and moved less than ``r / 2``.
    context : float
        Normalised correlation of the neighbourhood twice as large through ``affine`` (-1..1,
        ``-1`` when not ``ok``): a look-alike part elsewhere (the other hand) matches the
        small neighbourhood but rarely its surroundings.
    """

    xy: np.ndarray
    rho: float
    affine: np.ndarray
    ok: bool
    context: float = -1.0


def patch_radius(gray: np.ndarray, xy, radii, *, min_eig: float = 1500.0) -> int:
    """The smallest radius of ``radii`` whose neighbourhood of ``xy`` on ``gray`` pins a shift down.

    The smaller eigenvalue of the structure tensor (sum of gradient outer products, Sobel / 8)
    must reach ``min_eig``: edges in two directions. A small neighbourhood keeps the alignment
    local (limbs bend around a joint); a flat one has to reach out to the nearest outlines.
    The largest radius when none does.
    """
    x, y = int(round(xy[0])), int(round(xy[1]))
    big = int(max(radii)) + 1
    h, w = gray.shape
    x0, y0 = max(x - big, 0), max(y - big, 0)
    g = gray[y0:min(y + big + 1, h), x0:min(x + big + 1, w)].astype(np.float32)
    if g.size == 0:
        return int(max(radii))
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / 8
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / 8
    cx, cy = x - x0, y - y0
    for r in sorted(radii):
        sl = (slice(max(cy - r, 0), cy + r + 1), slice(max(cx - r, 0), cx + r + 1))
        a, b, c = float((gx[sl] ** 2).sum()), float((gx[sl] * gy[sl]).sum()), float((gy[sl] ** 2).sum())
        if 0.5 * (a + c) - np.sqrt(0.25 * (a - c) ** 2 + b * b) >= min_eig:
            return int(r)
    return int(max(radii))


_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 15, 1e-4)


def refine(ref_gray: np.ndarray, ref_xy, cur_gray: np.ndarray, affine: np.ndarray, *, r: int = 24,
           search: int = 12, wide: int = 0, min_rho: float = 0.8, with_context: bool = True, motion: int = cv2.MOTION_EUCLIDEAN) -> Refined:
    """Align the neighbourhood of ``ref_xy`` on ``ref_gray`` to ``cur_gray``.

    Parameters
    ----------
    ref_gray, cur_gray : (H, W) uint8 arrays
    ref_xy : (2,) float
        The joint on the reference frame.
    affine : (2, 3) float array
        Predicted map reference -> current around the joint.
    r : int
        Half size of the neighbourhood in pixels.
    search : int
        Extra margin of the current frame's window around the prediction.
    with_context : bool
        Measure :attr:`Refined.context` (else it stays -1).
    wide : int
        When ECC fails from the prediction, look for the neighbourhood by normalised correlation
        (``cv2.matchTemplate``) this far around it and run ECC from there (0: do not).
    """
    affine = np.asarray(affine, np.float64)
    pred = affine @ np.append(np.asarray(ref_xy, np.float64), 1.0)
    fail = Refined(pred, 0.0, affine, False)
    H, W = cur_gray.shape
    px, py = int(round(pred[0])) - r, int(round(pred[1])) - r
    n = 2 * r + 1
    # template: the reference frame seen through the predicted map, on the window around pred
    M = affine.copy()
    M[:, 2] -= (px, py)
    tmpl = cv2.warpAffine(ref_gray, M, (n, n), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    if float(tmpl.std()) < 2.0:
        return fail  # flat: nothing to align
    x0, y0 = max(px - search, 0), max(py - search, 0)
    x1, y1 = min(px + n + search, W), min(py + n + search, H)
    if x1 - x0 < n // 2 or y1 - y0 < n // 2:
        return fail
    win = cur_gray[y0:y1, x0:x1]
    start = (px - x0, py - y0)
    here = win[start[1]:start[1] + n, start[0]:start[0] + n]
    if here.shape == tmpl.shape and np.array_equal(here, tmpl):  # already in place (ECC's smoothing would nudge it)
        ctx = context(ref_gray, ref_xy, cur_gray, affine, 2 * r) if with_context else -1.0
        return Refined(pred, 1.0, affine, True, ctx)
    rho, warp = _ecc(tmpl, win, start, motion)
    u = pred - (px, py)
    xy = warp[:, :2].astype(np.float64) @ u + warp[:, 2] + (x0, y0)
    if not (rho >= min_rho and np.hypot(*(xy - pred)) <= r / 2) and wide > 0:
        # far from the prediction: the best normalised-correlation spot of a wider window
        x0, y0 = max(px - wide, 0), max(py - wide, 0)
        x1, y1 = min(px + n + wide, W), min(py + n + wide, H)
        if x1 - x0 >= n and y1 - y0 >= n:
            win = cur_gray[y0:y1, x0:x1]
            score = cv2.matchTemplate(win, tmpl, cv2.TM_CCOEFF_NORMED)
            _, peak, _, (bx, by) = cv2.minMaxLoc(score)
            if peak >= min_rho:
                rho, warp = _ecc(tmpl, win, (bx, by), motion)
                xy = warp[:, :2].astype(np.float64) @ u + warp[:, 2] + (x0, y0)
                far = np.hypot(*(xy - (pred + (bx + x0 - px, by + y0 - py)))) > r / 2
                if far:
                    rho = 0.0
                if rho >= min_rho:
                    return _done(xy, rho, warp, affine, px, py, x0, y0, ref_gray, ref_xy, cur_gray, r, with_context)
        return Refined(pred, float(rho), affine, False)
    if not (rho >= min_rho and np.hypot(*(xy - pred)) <= r / 2):
        return Refined(pred, float(rho), affine, False)
    return _done(xy, rho, warp, affine, px, py, x0, y0, ref_gray, ref_xy, cur_gray, r, with_context)


def _ecc(tmpl: np.ndarray, win: np.ndarray, start, motion: int) -> tuple[float, np.ndarray]:
    """ECC from a translation ``start`` of the template in ``win``; (rho, (2, 3) warp), rho 0 on failure."""
    warp = np.array([[1, 0, start[0]], [0, 1, start[1]]], np.float32)
    try:
        rho, warp = cv2.findTransformECC(tmpl, win, warp, motion, _CRITERIA, None, 3)
    except cv2.error:
        return 0.0, warp
    return float(rho), warp


def _done(xy, rho, warp, affine, px, py, x0, y0, ref_gray, ref_xy, cur_gray, r, with_context) -> Refined:
    # current = warp(template coords) = warp(affine(ref) - (px, py)) + (x0, y0)
    Wl = warp[:, :2].astype(np.float64)
    new = np.hstack([Wl @ affine[:, :2], (Wl @ (affine[:, 2] - (px, py)) + warp[:, 2] + (x0, y0))[:, None]])
    ctx = context(ref_gray, ref_xy, cur_gray, new, 2 * r) if with_context else -1.0
    return Refined(xy, float(rho), new, True, ctx)


def context(ref_gray: np.ndarray, ref_xy, cur_gray: np.ndarray, affine: np.ndarray, r: int) -> float:
    """Normalised correlation of the reference neighbourhood of ``ref_xy`` (half size ``r``),
    seen through ``affine``, with the current frame around where it lands."""
    q = affine @ np.append(np.asarray(ref_xy, np.float64), 1.0)
    n = 2 * r + 1
    px, py = int(round(q[0])) - r, int(round(q[1])) - r
    M = affine.copy()
    M[:, 2] -= (px, py)
    a = cv2.warpAffine(ref_gray, M, (n, n), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    S = np.float64([[1, 0, -px], [0, 1, -py]])
    b = cv2.warpAffine(cur_gray, S, (n, n), flags=cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
    if a.std() < 1e-6 or b.std() < 1e-6:
        return 0.0
    return float(cv2.matchTemplate(b, a, cv2.TM_CCOEFF_NORMED)[0, 0])
