"""The canvas view transform: canvas pixels <-> window pixels (top-down, as ImGui's).

``screen = canvas * scale + origin``. Zoom keeps the canvas point under the cursor
fixed; fit centres the whole canvas in the canvas area on whole pixels.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_SCALE, MAX_SCALE = 1.0 / 64, 64.0
#: wheel notch -> zoom factor
WHEEL_STEP = 1.2


@dataclass
class View:
    """Where the canvas is drawn in the window.

    Attributes
    ----------
    scale : float
        Window pixels per canvas pixel.
    origin : (float, float)
        Window position (x right, y down) of canvas point (0, 0).
    """

    scale: float = 1.0
    origin: tuple[float, float] = (0.0, 0.0)

    def to_screen(self, xy) -> np.ndarray:
        """Canvas points (..., 2) -> window points (..., 2)."""
        return np.asarray(xy, float) * self.scale + np.asarray(self.origin, float)

    def to_canvas(self, xy) -> np.ndarray:
        """Window points (..., 2) -> canvas points (..., 2)."""
        return (np.asarray(xy, float) - np.asarray(self.origin, float)) / self.scale

    def zoom_at(self, screen_xy, factor: float) -> None:
        """Multiply the scale by ``factor`` (clamped) keeping the point under ``screen_xy`` fixed."""
        c = self.to_canvas(screen_xy)
        self.scale = float(np.clip(self.scale * factor, MIN_SCALE, MAX_SCALE))
        s = np.asarray(screen_xy, float) - c * self.scale
        self.origin = (float(s[0]), float(s[1]))

    def pan(self, dx: float, dy: float) -> None:
        self.origin = (self.origin[0] + dx, self.origin[1] + dy)

    def fit(self, canvas: tuple[int, int], rect: tuple[float, float, float, float], margin: float = 12) -> None:
        """Show the whole canvas (W, H) centred in window rect (x, y, w, h)."""
        x, y, w, h = rect
        cw, ch = canvas
        s = min((w - 2 * margin) / cw, (h - 2 * margin) / ch)
        self.scale = float(np.clip(s, MIN_SCALE, MAX_SCALE))
        self.origin = (float(round(x + (w - cw * self.scale) / 2)), float(round(y + (h - ch * self.scale) / 2)))

    def canvas_rect(self, canvas: tuple[int, int]) -> tuple[float, float, float, float]:
        """The canvas on the window: (x, y, w, h)."""
        return (self.origin[0], self.origin[1], canvas[0] * self.scale, canvas[1] * self.scale)

    def visible(self, canvas: tuple[int, int], area: tuple[float, float, float, float]):
        """The part of the canvas that shows in window rect ``area``, on whole window pixels.

        Returns
        -------
        None when nothing shows, else ``(x0, y0, x1, y1)`` window pixels (ints) and the
        canvas rect ``(cx, cy, cw, ch)`` they show.
        """
        ox, oy, w, h = self.canvas_rect(canvas)
        ax, ay, aw, ah = area
        x0, y0 = max(int(np.floor(ox)), int(np.floor(ax))), max(int(np.floor(oy)), int(np.floor(ay)))
        x1, y1 = min(int(np.ceil(ox + w)), int(np.ceil(ax + aw))), min(int(np.ceil(oy + h)), int(np.ceil(ay + ah)))
        if x1 <= x0 or y1 <= y0:
            return None
        c0 = self.to_canvas((x0, y0))
        return (x0, y0, x1, y1), (float(c0[0]), float(c0[1]), (x1 - x0) / self.scale, (y1 - y0) / self.scale)
