"""The dressing room's per-pixel depth, as the page reads it: a garment's pin depth (drawn
on the GPU: :meth:`puppet.api.Scene.pin_depth`, whose CPU reference is
``tests/room/reference.py``) grown by a pixel over the soft edge (:func:`grow`), and
coded into a PNG (:func:`depth_rgba`).
"""
from __future__ import annotations

import cv2
import numpy as np

#: Depth codes of the page's depth images: ``round((d - LOW) * STEPS)`` in 0..65535, so
#: depths from -128 to +128 stacking units in steps of 1/256.
LOW, STEPS = -128.0, 256.0


def grow(front: np.ndarray) -> np.ndarray:
    """A pin-depth map (NaN or -inf where nothing shows) grown by one pixel (the largest
    of the 3x3 neighbours) into the pixels around, where the compositor's soft edges
    still draw some of the garment; float64, NaN where nothing is."""
    front = np.where(np.isnan(front), -np.inf, np.asarray(front, np.float64))
    grown = cv2.dilate(front, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    return np.where(np.isfinite(front), front, np.where(np.isfinite(grown), grown, np.nan))


def depth_rgba(depth: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint8 image of a depth map for the page: red and green the high and low
    bytes of the code (:data:`LOW`, :data:`STEPS`), blue 255 where a depth is given and 0
    where not, alpha always 255 (so that a browser's premultiplied canvas keeps the bytes)."""
    covered = ~np.isnan(depth)
    code = np.clip(np.rint((np.where(covered, depth, LOW) - LOW) * STEPS), 0, 65535).astype(np.uint32)
    out = np.empty(depth.shape + (4,), np.uint8)
    out[..., 0], out[..., 1] = code >> 8, code & 255
    out[..., 2], out[..., 3] = np.where(covered, 255, 0), 255
    return out
