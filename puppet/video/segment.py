"""The character's mask on every frame, by the rule of the scene's layer.

The same mask options as a layer (:mod:`puppet.imaging.masks`): ``alpha`` (frames with
transparency), ``threshold`` (and ``invert``), and ``grabcut``: the rectangle is used
on the start frame only; every next frame runs GrabCut seeded from the previous
frame's mask (probably-foreground inside it, probably-background in a band around it,
background beyond) on the band's bounding box (at half resolution when it is large). A layer without a
mask takes the default rule of a still scene, chosen on the start frame (alpha when it
has transparency, else threshold 250 on white). Fixed shapes (``polygon``, ``rect``,
``file``) cannot follow a moving character and are refused.

Each mask is cleaned: holes inside the character are filled (eye whites under a
threshold) and specks smaller than 2 % of the largest part are dropped (compression
noise).
"""
from __future__ import annotations

import numpy as np

from puppet.errors import SceneError
from puppet.imaging import masks as mk

__all__ = ["Segmenter", "clean_mask"]

#: Parts smaller than this fraction of the largest one are dropped.
SPECK = 0.02
#: Band around the previous mask that GrabCut may grow into, px (at full resolution).
GRABCUT_BAND = 24
#: GrabCut runs at half resolution on boxes larger than this many pixels.
HALF_AREA = 160_000


def clean_mask(mask: np.ndarray) -> np.ndarray:
    """Fill holes and drop specks: (H, W) bool -> (H, W) bool."""
    import cv2

    x, y, w, h = cv2.boundingRect(mask.astype(np.uint8))
    out = np.zeros_like(mask, dtype=bool)
    if w == 0:
        return out
    H, W = mask.shape
    x0, y0, x1, y1 = max(x - 1, 0), max(y - 1, 0), min(x + w + 1, W), min(y + h + 1, H)
    out[y0:y1, x0:x1] = _clean(mask[y0:y1, x0:x1])
    return out


def _clean(mask: np.ndarray) -> np.ndarray:
    import cv2

    m8 = mask.astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m8, connectivity=8)
    if n <= 1:
        return mask.copy()
    area = stats[1:, cv2.CC_STAT_AREA]
    keep = np.r_[False, area >= max(SPECK * area.max(), 1)]
    m = keep[labels]
    # holes: background parts that do not touch the border
    inv = (~m).astype(np.uint8)
    n2, lab2, st2, _ = cv2.connectedComponentsWithStats(inv, connectivity=4)
    if n2 > 2:
        H, W = m.shape
        x, y, w, h = (st2[:, c] for c in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                         cv2.CC_STAT_HEIGHT))
        border = (x == 0) | (y == 0) | (x + w == W) | (y + h == H)
        hole = np.r_[False, ~border[1:]]
        m |= hole[lab2]
    return m


class Segmenter:
    """Masks frame after frame by one layer's rule.

    Parameters
    ----------
    layer : the scene's :class:`~puppet.scene.format.model.Layer` (its ``mask``, ``offset`` and ``name``).
    first : (H, W, 4) uint8 start frame (decides the default rule).
    scene_file : for error messages.
    """

    def __init__(self, layer, first: np.ndarray, *, scene_file: str | None = None):
        M = layer.mask
        path = f"layers[{layer.index}].mask"
        if M is None:
            self.kind, self.threshold, self.invert = ("alpha", 0.0, False) if mk.has_transparency(first) \
                else ("threshold", 250.0, False)
        elif M.kind in ("alpha", "threshold", "grabcut"):
            self.kind, self.threshold, self.invert = M.kind, M.threshold, M.invert
        else:
            raise SceneError(f"a video scene's layer mask must be alpha, threshold or grabcut "
                             f"(a fixed {M.kind} cannot follow the character)", file=scene_file, path=path)
        self.rect, self.offset = (M.rect if M is not None else None), layer.offset
        self.prev: np.ndarray | None = None

    def __call__(self, rgba: np.ndarray) -> np.ndarray:
        """The (H, W) bool mask of the next frame (``rgba`` (H, W, 4) uint8)."""
        if self.kind == "alpha":
            m = mk.alpha_mask(rgba)
        elif self.kind == "threshold":
            m = _threshold(rgba, self.threshold, self.invert)
        elif self.prev is None:
            m = mk.grabcut_mask(rgba, self.rect, self.offset) & (rgba[..., 3] > 0)
        else:
            m = _grabcut_from(rgba, self.prev) & (rgba[..., 3] > 0)
        m = clean_mask(m)
        if not m.any() and self.prev is not None:
            m = self.prev.copy()  # the character vanished: keep the last mask (tracking reports it)
        self.prev = m
        return m


def _threshold(rgba: np.ndarray, threshold: float, invert: bool) -> np.ndarray:
    """:func:`puppet.imaging.masks.threshold_mask` in integer arithmetic (Rec. 601 luma
    in thousandths: ``299 R + 587 G + 114 B < 1000 T``), a few times faster per frame."""
    r = rgba[..., 0].astype(np.int32)
    r *= 299
    r += 587 * rgba[..., 1].astype(np.int32)
    r += 114 * rgba[..., 2].astype(np.int32)
    m = r < int(round(1000 * threshold))
    if invert:
        m = ~m
    return m & (rgba[..., 3] > 0)


def _grabcut_from(rgba: np.ndarray, prev: np.ndarray, iterations: int = 2) -> np.ndarray:
    """GrabCut seeded from the previous mask, on the band's bounding box (at half size
    when it is larger than :data:`HALF_AREA` pixels)."""
    import cv2

    H, W = prev.shape
    if not prev.any():
        return prev.copy()
    k = np.ones((2 * GRABCUT_BAND + 1, 2 * GRABCUT_BAND + 1), np.uint8)
    band = cv2.dilate(prev.astype(np.uint8), k) > 0
    core = cv2.erode(prev.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
    ys, xs = np.nonzero(band)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    seed = np.full((y1 - y0, x1 - x0), cv2.GC_BGD, np.uint8)
    seed[band[y0:y1, x0:x1]] = cv2.GC_PR_BGD
    seed[prev[y0:y1, x0:x1]] = cv2.GC_PR_FGD
    seed[core[y0:y1, x0:x1]] = cv2.GC_PR_FGD
    bgr = np.ascontiguousarray(rgba[y0:y1, x0:x1, 2::-1])
    half = 2 if (x1 - x0) * (y1 - y0) > HALF_AREA else 1
    sw, sh = max(2, (x1 - x0) // half), max(2, (y1 - y0) // half)
    if (sw, sh) == (x1 - x0, y1 - y0):  # small enough: GrabCut at full size
        small, s_seed = bgr, seed
    else:
        small = cv2.resize(bgr, (sw, sh), interpolation=cv2.INTER_AREA)
        s_seed = cv2.resize(seed, (sw, sh), interpolation=cv2.INTER_NEAREST)
    if not ((s_seed == cv2.GC_PR_FGD).any() and (s_seed != cv2.GC_PR_FGD).any()):
        return prev.copy()
    bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)
    try:
        cv2.grabCut(small, s_seed, None, bgd, fgd, iterations, cv2.GC_INIT_WITH_MASK)
    except cv2.error:
        return prev.copy()
    fg = ((s_seed == cv2.GC_FGD) | (s_seed == cv2.GC_PR_FGD)).astype(np.uint8)
    out = np.zeros((H, W), bool)
    if fg.shape != (y1 - y0, x1 - x0):
        fg = cv2.resize(fg, (x1 - x0, y1 - y0), interpolation=cv2.INTER_NEAREST)
    out[y0:y1, x0:x1] = fg > 0
    return out
