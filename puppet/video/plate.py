"""A clean plate: the background as last seen, gathered frame after frame.

Where the character uncovers a spot that an earlier frame showed without the character,
that earlier pixel is the true background and beats any inpainting. The plate keeps, for
every pixel, its colour on the last frame where it was outside the character (the mask
grown by ``grow`` px, so its soft edge never enters). A static camera is assumed and
checked: when the plate no longer matches the frame around the character (the camera
moved, the light changed), it is dropped and gathered again.
"""
from __future__ import annotations

import numpy as np

__all__ = ["Plate"]


class Plate:
    """Background pixels seen so far.

    Parameters
    ----------
    grow : px the mask is grown by (the character's soft edge).
    tolerance : mean absolute difference (0-255) around the character above which the
        plate is taken to be stale and dropped.
    """

    def __init__(self, *, grow: int = 3, tolerance: float = 6.0):
        self.grow, self.tolerance = grow, tolerance
        self.rgb: np.ndarray | None = None
        self.seen: np.ndarray | None = None

    def _hole(self, mask: np.ndarray) -> np.ndarray:
        import cv2

        k = np.ones((2 * self.grow + 1, 2 * self.grow + 1), np.uint8)
        return cv2.dilate(mask.astype(np.uint8), k) > 0

    def apply(self, rgb: np.ndarray, mask: np.ndarray, filled: np.ndarray) -> np.ndarray:
        """``filled`` (the frame with the character inpainted) with the plate's pixels where
        the character is and the plate has seen the background; then the plate learns
        this frame. All (H, W, 3) uint8, ``mask`` (H, W) bool."""
        import cv2

        hole = self._hole(mask)
        out = filled
        if self.rgb is not None:
            ring = (cv2.dilate(hole.astype(np.uint8), np.ones((17, 17), np.uint8)) > 0) & ~hole & self.seen
            if ring.any():
                diff = np.abs(self.rgb[ring].astype(np.int16) - rgb[ring].astype(np.int16)).mean()
                if diff > self.tolerance:  # stale: the camera or the light changed
                    self.seen[:] = False
            use = hole & self.seen
            if use.any():
                out = filled.copy()
                out[use] = self.rgb[use]
        if self.rgb is None:
            self.rgb = rgb.copy()
            self.seen = ~hole
        else:
            np.copyto(self.rgb, rgb, where=~hole[..., None])
            self.seen |= ~hole
        return out
