"""Drive the app in a headless pyglet window (EGL, no X): synthetic pyglet events in,
model and framebuffer pixels out."""
from __future__ import annotations

import os
import time

import numpy as np
import pyglet

pyglet.options["headless"] = True
pyglet.options["debug_gl"] = False

from pyglet.window import key, mouse  # noqa: E402

from puppet.app.gl.window import AppWindow  # noqa: E402

DOCS_SHOTS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs", "app")


class Driver:
    """An app window and the hands that use it. Window coordinates are top-down (as
    ImGui's); pyglet's bottom-up y is handled here."""

    def __init__(self, path=None, size=(960, 640), **kw):
        pyglet.window.Window._enable_event_queue = True
        self.ready = {}
        self.w = AppWindow(path, size=size, visible=False, ready=self.ready.update, **kw)
        self.app = self.w.app
        self.size = tuple(self.w.win.get_size())  # a size under the window's minimum is raised to it
        self.pos = (self.size[0] // 2, self.size[1] // 2)
        self.mods = 0
        self.settle()

    # -- time -----------------------------------------------------------------------
    def frame(self, n: int = 1) -> None:
        for _ in range(n):
            self.w.frame()

    def settle(self, timeout: float = 60.0) -> None:
        """Draw frames until the scene thread has run every job and its result is shown."""
        end = time.monotonic() + timeout
        self.frame()
        while time.monotonic() < end:
            session = self.app.session
            # (a dialog's follow-up, e.g. the open after "Don't save", runs in a later frame)
            if session.idle() and session.latest is self.app.snap and self.w._then is None:
                break
            time.sleep(0.005)
            self.frame()
        else:
            raise TimeoutError("the app did not settle")
        self.frame(2)

    # -- input ----------------------------------------------------------------------
    def _y(self, y):
        return self.size[1] - y

    def move(self, x, y) -> None:
        dx, dy = x - self.pos[0], y - self.pos[1]
        self.pos = (x, y)
        self.w.win.dispatch_event("on_mouse_motion", x, self._y(y), dx, -dy)
        self.frame()

    def press(self, x, y, button=mouse.LEFT, mods=0) -> None:
        self.move(x, y)
        self.w.win.dispatch_event("on_mouse_press", x, self._y(y), button, mods)
        self.frame()

    def drag(self, x, y, button=mouse.LEFT, mods=0) -> None:
        dx, dy = x - self.pos[0], y - self.pos[1]
        self.pos = (x, y)
        self.w.win.dispatch_event("on_mouse_drag", x, self._y(y), dx, -dy, button, mods)
        self.frame()

    def release(self, x=None, y=None, button=mouse.LEFT, mods=0) -> None:
        x, y = self.pos if x is None else (x, y)
        self.w.win.dispatch_event("on_mouse_release", x, self._y(y), button, mods)
        self.frame()

    def click(self, x, y, button=mouse.LEFT, mods=0) -> None:
        self.press(x, y, button, mods)
        self.release(x, y, button, mods)

    def drag_path(self, points, button=mouse.LEFT, mods=0, settle_each=False) -> None:
        self.press(*points[0], button=button, mods=mods)
        for p in points[1:]:
            self.drag(*p, button=button, mods=mods)
            if settle_each:
                self.settle()
        self.release(*points[-1], button=button, mods=mods)

    def grab(self, pin: str, dy: float, pose: str | None = None):
        """Make ``pose`` active (if given), press pin ``pin`` and drag it ``dy`` window px
        up, settled: a drag held in progress. Returns the pin's screen point at the press."""
        if pose is not None:
            self.app.edit(lambda s: s.set_active_pose(pose))
            self.settle()
        start = self.pin_screen(pin)
        self.press(*start)
        self.drag(start[0], start[1] - dy)
        self.settle()
        return start

    def key(self, symbol, mods=0) -> None:
        mod_keys = [(key.MOD_CTRL, key.LCTRL), (key.MOD_SHIFT, key.LSHIFT), (key.MOD_ALT, key.LALT)]
        for m, k in mod_keys:
            if mods & m:
                self.w.win.dispatch_event("on_key_press", k, mods)
        self.w.win.dispatch_event("on_key_press", symbol, mods)
        self.frame()
        self.w.win.dispatch_event("on_key_release", symbol, mods)
        for m, k in mod_keys:
            if mods & m:
                self.w.win.dispatch_event("on_key_release", k, 0)
        self.frame()

    def type(self, text: str) -> None:
        self.w.win.dispatch_event("on_text", text)
        self.frame()

    def scroll(self, x, y, notches: float) -> None:
        self.move(x, y)
        self.w.win.dispatch_event("on_mouse_scroll", x, self._y(y), 0, notches)
        self.frame()

    # -- looking --------------------------------------------------------------------
    def pixels(self) -> np.ndarray:
        """The window as (H, W, 3) uint8, row 0 at the top."""
        ctx = self.w.ctx
        data = ctx.screen.read(components=3)
        ctx.error  # read() leaves a GL error flag set
        return np.frombuffer(data, np.uint8).reshape(self.size[1], self.size[0], 3)[::-1].copy()

    def screen_of(self, xy):
        """Window position (top-down) of canvas point ``xy``."""
        p = self.app.view.to_screen(xy)
        return float(p[0]), float(p[1])

    def pin_screen(self, name: str):
        m = self.app.marker(name)
        assert m is not None, f"no marker {name}"
        return self.screen_of(self.app.marker_xy(m))

    def scene(self):
        """The scene object (read it only while the app is settled)."""
        return self.app.session.scene

    def shot(self, name: str) -> str:
        """Save the window as docs/app/NAME.png (unchanged files are not rewritten)."""
        from PIL import Image
        import io

        os.makedirs(DOCS_SHOTS, exist_ok=True)
        path = os.path.join(DOCS_SHOTS, name + ".png")
        buf = io.BytesIO()
        Image.fromarray(self.pixels()).save(buf, format="PNG", optimize=True)
        data = buf.getvalue()
        if not os.path.exists(path) or open(path, "rb").read() != data:
            with open(path, "wb") as f:
                f.write(data)
        return path

    def close(self) -> None:
        self.w.close()


def pin_keys(keys, pin: str) -> dict[float, list[float]]:
    """{time: [x, y]} of the animation keys (file form) that hold ``pin``'s target: a pins
    key, or a pose key's ``overrides`` (either way a key can carry a pin)."""
    out = {}
    for k in keys:
        v = k.get("pins", {}).get(pin, (k.get("overrides") or {}).get(pin))
        if v is not None:
            out[float(k["time"])] = list(v["to"] if isinstance(v, dict) else v)
    return out


def widget(label: str):
    """Centre of the widget drawn last under ``label`` (see puppet.app.ui.widgets.RECTS)."""
    from puppet.app.ui.widgets import RECTS

    x0, y0, x1, y1 = RECTS[label]
    return (x0 + x1) / 2, (y0 + y1) / 2
