"""Small ImGui helpers shared by the panels: buttons with tooltips, live sliders that
make one undo step per drag, layer thumbnails."""
from __future__ import annotations

import moderngl
import numpy as np
from imgui_bundle import imgui

THUMB = 36  # thumbnail size, window pixels
#: where each named widget was drawn in the last frames: label -> (x0, y0, x1, y1) window
#: pixels (tests and the docs' screenshots find buttons with it)
RECTS: dict[str, tuple[float, float, float, float]] = {}


def note(label: str) -> None:
    """Record the last item's rectangle under ``label`` in :data:`RECTS`."""
    a, b = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    RECTS[label] = (a.x, a.y, b.x, b.y)


def button(label: str, tip: str, enabled: bool = True, small: bool = False) -> bool:
    """A button with a tooltip (shown also when disabled); True when clicked."""
    imgui.begin_disabled(not enabled)
    clicked = imgui.small_button(label) if small else imgui.button(label)
    imgui.end_disabled()
    imgui.set_item_tooltip(tip)
    note(label)
    return clicked and enabled


#: a dialog's error text colour
ERROR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)


def message(text: str, failed: bool, width: float) -> None:
    """A dialog's wrapped message line(s), in :data:`ERROR` red when ``failed``."""
    imgui.push_text_wrap_pos(imgui.get_cursor_pos_x() + width)
    if failed:
        imgui.text_colored(ERROR, text)
    else:
        imgui.text(text)
    imgui.pop_text_wrap_pos()


def close_button(app, label: str = "Close", said: str = "", failed: bool = False) -> bool:
    """A dialog's Close button (or Esc): the dialog closes and the status line repeats
    ``said`` (how its run ended, red when ``failed``); True when it closed."""
    if not (button(label, "close this dialog (Esc)") or imgui.is_key_pressed(imgui.Key.escape)):
        return False
    if said:
        app.say(said, "error" if failed else "info")
    app.dialog = None
    imgui.close_current_popup()
    return True


def toggle(label: str, value: bool, tip: str) -> bool:
    """A checkbox with a tooltip; returns the new value."""
    _, value = imgui.checkbox(label, value)
    imgui.set_item_tooltip(tip)
    note(label)
    return value


def live(app, key: str, label: str) -> None:
    """Call right after a slider: its whole drag is one undo step (a block on the scene
    thread opened when the slider is grabbed and closed when it is released)."""
    if imgui.is_item_activated():
        app.begin_block(key, label)
    if imgui.is_item_deactivated():
        app.end_block(key)


class Thumbs:
    """Layer thumbnails as GL textures registered with the ImGui renderer, by image key."""

    def __init__(self, ctx: moderngl.Context, gui):
        self.ctx, self.gui = ctx, gui
        self.cache: dict[str, moderngl.Texture] = {}

    def ref(self, key: str, rgba: np.ndarray):
        """(ImTextureRef, display size) of the thumbnail of image ``rgba`` cached as ``key``."""
        tex = self.cache.get(key)
        if tex is None:
            tex = self.cache[key] = self._make(rgba)
            self.gui.register(tex)
            if len(self.cache) > 256:  # forget the oldest
                old = next(iter(self.cache))
                self.gui.unregister(self.cache[old])
                self.cache.pop(old).release()
        w, h = tex.size
        s = THUMB / max(w, h)
        return self.gui.ref(tex), (w * s, h * s)

    def _make(self, rgba: np.ndarray) -> moderngl.Texture:
        rgba = crop_visible(rgba)
        h, w = rgba.shape[:2]
        step = max(1, int(np.ceil(max(h, w) / (2 * THUMB))))
        small = np.ascontiguousarray(rgba[::step, ::step])
        tex = self.ctx.texture((small.shape[1], small.shape[0]), 4, small.tobytes())
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        return tex

    def release(self) -> None:
        for tex in self.cache.values():
            self.gui.unregister(tex)
            tex.release()
        self.cache.clear()


def crop_visible(rgba: np.ndarray) -> np.ndarray:
    """The bounding box of the pixels with alpha > 0 (the whole image when none)."""
    ys, xs = np.nonzero(rgba[..., 3])
    if not len(ys):
        return rgba
    return rgba[ys.min():ys.max() + 1, xs.min():xs.max() + 1]
