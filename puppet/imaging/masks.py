"""Layer masks: which pixels of a layer's image belong to the layer.

All functions return (h, w) bool arrays in the pixel grid of the layer's image; shapes
given in canvas coordinates are shifted by the layer's offset first.
"""
from __future__ import annotations

import numpy as np


def has_transparency(rgba: np.ndarray) -> bool:
    """True when any pixel of an (h, w, 4) image is not fully opaque."""
    return bool((rgba[..., 3] < 255).any())


def luminance(rgba: np.ndarray) -> np.ndarray:
    """Rec. 601 luma of an (h, w, 4) uint8 image, (h, w) float in 0..255."""
    rgb = rgba[..., :3].astype(np.float32)
    return rgb @ np.array([0.299, 0.587, 0.114], np.float32)


def alpha_mask(rgba: np.ndarray) -> np.ndarray:
    """Pixels with alpha > 0."""
    return rgba[..., 3] > 0


def threshold_mask(rgba: np.ndarray, threshold: float, invert: bool = False) -> np.ndarray:
    """Pixels darker than ``threshold`` (luminance < T) are object; ``invert`` flips.

    Fully transparent pixels are never object.
    """
    m = luminance(rgba) < threshold
    if invert:
        m = ~m
    return m & (rgba[..., 3] > 0)


def polygon_mask(shape: tuple[int, int], polygon: np.ndarray, offset=(0.0, 0.0)) -> np.ndarray:
    """Pixels whose centre lies inside a polygon given in canvas coordinates.

    Even-odd rule, scanline by scanline: every pixel row's centre line is cut with the
    polygon's edges (half-open in y, so a vertex on the line counts once) and the runs
    between pairs of crossings are filled (a centre exactly on an edge counts as inside
    on the left edge, outside on the right one).
    """
    h, w = shape
    P = np.asarray(polygon, np.float64) - np.asarray(offset, np.float64)
    A, B = P, np.roll(P, -1, axis=0)
    keep = A[:, 1] != B[:, 1]
    A, B = A[keep], B[keep]
    y0 = np.minimum(A[:, 1], B[:, 1])
    y1 = np.maximum(A[:, 1], B[:, 1])
    # rows whose centre y = i + 0.5 satisfies y0 <= y < y1
    r0 = np.clip(np.ceil(y0 - 0.5), 0, h).astype(np.int64)
    r1 = np.clip(np.ceil(y1 - 0.5), 0, h).astype(np.int64)
    counts = np.maximum(r1 - r0, 0)
    edge = np.repeat(np.arange(len(A)), counts)
    row = np.repeat(r0, counts) + (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    y = row + 0.5
    a, b = A[edge], B[edge]
    x = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    order = np.lexsort((x, row))
    row, x = row[order], x[order]
    diff = np.zeros((h, w + 1), np.int32)
    # crossings come in pairs per row (closed polygon): fill [x_start, x_end)
    col = np.clip(np.ceil(x - 0.5), 0, w).astype(np.int64)
    sign = np.where(np.arange(len(x)) % 2 == 0, 1, -1)
    np.add.at(diff, (row, col), sign)
    return np.cumsum(diff[:, :w], axis=1) > 0


def rect_mask(shape: tuple[int, int], rect, offset=(0.0, 0.0)) -> np.ndarray:
    """Pixels whose centre lies inside ``[x, y, w, h]`` (canvas coordinates)."""
    h, w = shape
    x0, y0, rw, rh = (float(v) for v in rect)
    x0 -= offset[0]
    y0 -= offset[1]
    cx = np.arange(w) + 0.5
    cy = np.arange(h) + 0.5
    mx = (cx >= x0) & (cx < x0 + rw)
    my = (cy >= y0) & (cy < y0 + rh)
    return my[:, None] & mx[None, :]


def grabcut_mask(rgba: np.ndarray, rect, offset=(0.0, 0.0), iterations: int = 5) -> np.ndarray:
    """Foreground of a photo inside ``[x, y, w, h]`` by OpenCV's GrabCut."""
    import cv2

    h, w = rgba.shape[:2]
    x0 = int(round(rect[0] - offset[0]))
    y0 = int(round(rect[1] - offset[1]))
    rw, rh = int(round(rect[2])), int(round(rect[3]))
    x0, y0 = max(x0, 0), max(y0, 0)
    rw, rh = min(rw, w - x0), min(rh, h - y0)
    mask = np.zeros((h, w), np.uint8)
    if rw < 2 or rh < 2:
        return mask.astype(bool)
    bgr = np.ascontiguousarray(rgba[..., 2::-1])
    bgd = np.zeros((1, 65), np.float64)
    fgd = np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)
    cv2.grabCut(bgr, mask, (x0, y0, rw, rh), bgd, fgd, iterations, cv2.GC_INIT_WITH_RECT)
    return (mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)
