"""GrabCut (Rother et al. 2004, OpenCV's implementation) with bounded work on any picture.

OpenCV's GrabCut builds a graph over every pixel: a 64-megapixel picture takes ~14 GB
and minutes, and a rectangle that leaves fewer background (or foreground) pixels than
its colour models have components fails an assertion. Here:

- a rectangle covering (almost) the whole picture keeps a border of :data:`BORDER`
  pixels as background, so both colour models always have samples;
- a picture larger than :data:`WORK_PIXELS` is cut at a scale where it fits, and the
  mask is then refined at full size in tiles of at most :data:`TILE` pixels a side along
  the boundary only (each tile's own GrabCut, started from the upscaled mask: pixels
  farther than the band from the boundary keep their label).

So the working set is O(:data:`WORK_PIXELS`) whatever the picture's size.
"""
from __future__ import annotations

import numpy as np

#: Largest picture cut in one piece (pixels); larger ones are cut downscaled, then refined.
WORK_PIXELS = 1 << 20
#: Side of a refinement tile (pixels).
TILE = 512
#: Pixels kept as background at the picture's edge when the rectangle covers it all.
BORDER = 2
#: Samples each colour model needs at least (OpenCV's GMMs have 5 components).
MIN_SAMPLES = 16


def grabcut(bgr: np.ndarray, rect: tuple[int, int, int, int], iterations: int = 5) -> np.ndarray:
    """Foreground of ``bgr`` ((h, w, 3) uint8, contiguous) inside ``rect`` = (x, y, w, h)
    in pixels (inside the picture). Returns (h, w) bool; all False when the rectangle is
    too small to hold a foreground model."""
    h, w = bgr.shape[:2]
    rect = _with_background(rect, w, h)
    if rect is None:
        return np.zeros((h, w), bool)
    if h * w <= WORK_PIXELS:
        return _cut(bgr, rect, iterations)
    s = (WORK_PIXELS / (h * w)) ** 0.5
    import cv2

    small = cv2.resize(bgr, (max(1, int(w * s)), max(1, int(h * s))), interpolation=cv2.INTER_AREA)
    sh, sw = small.shape[:2]
    sx, sy = sw / w, sh / h
    x, y, rw, rh = rect
    srect = _with_background((int(x * sx), int(y * sy), max(2, int(rw * sx)), max(2, int(rh * sy))), sw, sh)
    if srect is None:
        return np.zeros((h, w), bool)
    coarse = _cut(small, srect, iterations).astype(np.uint8) * 255
    mask = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_LINEAR) >= 128
    outside = np.ones((h, w), bool)
    outside[y:y + rh, x:x + rw] = False
    mask &= ~outside
    return _refine(bgr, mask, outside, band=int(np.ceil(2 / min(sx, sy))) + 2)


def _with_background(rect, w: int, h: int):
    """``rect`` clipped to the picture, shrunk to leave a background border when it leaves
    fewer than :data:`MIN_SAMPLES` pixels outside; None when it holds too few inside."""
    x, y, rw, rh = rect
    x, y = max(0, x), max(0, y)
    rw, rh = min(rw, w - x), min(rh, h - y)
    if w * h - max(rw, 0) * max(rh, 0) < MIN_SAMPLES:
        x0, y0 = max(x, BORDER), max(y, BORDER)
        rw, rh = min(x + rw, w - BORDER) - x0, min(y + rh, h - BORDER) - y0
        x, y = x0, y0
    if rw < 2 or rh < 2 or rw * rh < MIN_SAMPLES or w * h - rw * rh < MIN_SAMPLES:
        return None
    return int(x), int(y), int(rw), int(rh)


def _cut(bgr: np.ndarray, rect, iterations: int) -> np.ndarray:
    import cv2

    mask = np.zeros(bgr.shape[:2], np.uint8)
    bgd = np.zeros((1, 65), np.float64)
    fgd = np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)
    cv2.grabCut(bgr, mask, rect, bgd, fgd, iterations, cv2.GC_INIT_WITH_RECT)
    return (mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)


def _refine(bgr: np.ndarray, mask: np.ndarray, outside: np.ndarray, band: int, iterations: int = 2) -> np.ndarray:
    """Re-cut ``mask`` at full size within ``band`` pixels of its boundary, tile by tile."""
    import cv2

    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * band + 1, 2 * band + 1))
    m8 = mask.astype(np.uint8)
    sure_fg = cv2.erode(m8, k).astype(bool)
    sure_bg = ~cv2.dilate(m8, k).astype(bool) | outside
    h, w = mask.shape
    out = mask.copy()
    for y in range(0, h, TILE):
        for x in range(0, w, TILE):
            fg, bg = sure_fg[y:y + TILE, x:x + TILE], sure_bg[y:y + TILE, x:x + TILE]
            if (fg | bg).all() or fg.sum() < MIN_SAMPLES or bg.sum() < MIN_SAMPLES:
                continue  # no boundary here, or too little of one side to model it
            init = np.where(fg, cv2.GC_FGD, np.where(bg, cv2.GC_BGD, np.where(
                mask[y:y + TILE, x:x + TILE], cv2.GC_PR_FGD, cv2.GC_PR_BGD))).astype(np.uint8)
            bgd = np.zeros((1, 65), np.float64)
            fgd = np.zeros((1, 65), np.float64)
            cv2.setRNGSeed(0)
            cv2.grabCut(np.ascontiguousarray(bgr[y:y + TILE, x:x + TILE]), init, None, bgd, fgd, iterations,
                        cv2.GC_INIT_WITH_MASK)
            out[y:y + TILE, x:x + TILE] = (init == cv2.GC_FGD) | (init == cv2.GC_PR_FGD)
    return out
