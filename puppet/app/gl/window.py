"""The pyglet window: a moderngl context on the window's own GL context, ImGui panels,
the canvas. It only translates pyglet events (to ImGui's input) and lays out a frame;
the tools, panels and actions do the rest.

Set ``pyglet.options["headless"]`` before importing this module to get an EGL window
with no X server (tests, benchmarks).
"""
from __future__ import annotations

import json
import os
import sys
import time

import imgui_bundle
import moderngl
import pyglet
import pyglet.window
from imgui_bundle import imgui

from puppet.app.gl.canvas import CanvasRenderer, depth_range
from puppet.app.gl.ghosts import GhostRenderer
from puppet.app.gl.imgui_renderer import ImGuiRenderer
from puppet.app.gl.keys import ImGuiInput
from puppet.app.model import autosave
from puppet.app.model.app import App
from puppet.app.model.opening import scene_file
from puppet.app.tools.dispatch import choose_tool
from puppet.app.tools.gestures import CanvasEvent
from puppet.app.ui import actions, deform_overlay, menus, overlay, script
from puppet.app.ui import start_page as startpage
from puppet.app.ui.files import Files
from puppet.app.ui.panels import Panels
from puppet.app.ui.timeline_panel import MIN_HEIGHT as TIMELINE_MIN
from puppet.app.ui.timeline_panel import TimelinePanel
from puppet.app.ui.widgets import RECTS, Thumbs

PANEL_WIDTH = 330


def panel_width(w: float) -> float:
    """The side panels' width in a window ``w`` wide: :data:`PANEL_WIDTH`, narrower (to
    280) in a small window so that the canvas keeps 70 % of the width."""
    return float(min(PANEL_WIDTH, max(280.0, 0.3 * w)))
#: the smallest window (every toolbar control and panel stays reachable down to it)
MIN_SIZE = (960, 640)
#: seconds a thread runs Python before it hands over the GIL: shorter than CPython's 5 ms
#: default, so that the window is not kept waiting while the scene thread runs Python
#: between its solves (which release the GIL)
SWITCH_INTERVAL = 0.001
#: most frames a second for input alone (a new snapshot is drawn at once); a dragged pin's
#: marker is drawn from the pointer, so it follows the pointer event by event while a solve
#: lags (a 60 Hz cap beat against 60 Hz pointer events and drew ~47 of their 60 frames)
MAX_FPS = 120.0
#: most frames a second for input alone while a canvas gesture waits for the scene thread (a
#: drag's solve in flight): a window frame holds the GIL through its GL calls (moderngl
#: keeps it), and on a 2-core machine drawing the pointer's pin marker at MAX_FPS starved
#: the solve (4K PSD: 233 ms a drag step in the app against 20 ms alone); new snapshots
#: are still drawn at once
DRAG_FPS = 30.0
#: frames a second that move the playhead while playing or recording (new frames: at once)
PLAY_FPS = 30.0
FIXED = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_move
         | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings
         | imgui.WindowFlags_.no_bring_to_front_on_focus)
FONT = os.path.join(os.path.dirname(imgui_bundle.__file__), "assets", "fonts", "DroidSans.ttf")


class _Input(ImGuiInput):
    """ImGui input that also notes that something happened (so the loop draws)."""

    touched = True

    def __getattribute__(self, name):
        if name.startswith("on_"):
            object.__setattr__(self, "touched", True)
        return object.__getattribute__(self, name)


class AppWindow:
    """``puppet app``: one window on one scene (or none, with File > Open).

    Parameters
    ----------
    path : str, optional
        Scene to open (offering to recover its autosave if one is newer).
    size : (int, int)
        Window size.
    visible : bool
        Show the window (False in tests: a headless window is never shown).
    ready : callable, optional
        Called once with a dict (canvas rect, scale, window size) after the first frame
        that shows the scene; the CLI prints it as the ready line.
    """

    def __init__(self, path: str | None = None, *, size=(1280, 800), visible: bool = True, ready=None,
                 autosave_interval: float = autosave.INTERVAL):
        config = pyglet.gl.Config(double_buffer=True, red_size=8, green_size=8, blue_size=8, alpha_size=8,
                                  depth_size=24, major_version=3, minor_version=3, forward_compatible=True)
        size = (max(int(size[0]), MIN_SIZE[0]), max(int(size[1]), MIN_SIZE[1]))
        self.win = pyglet.window.Window(int(size[0]), int(size[1]), caption="puppet", resizable=True,
                                        config=config, visible=visible, file_drops=True)
        self.win.set_minimum_size(*MIN_SIZE)
        self._toolbar_width = 0.0
        sys.setswitchinterval(SWITCH_INTERVAL)
        self.win.switch_to()
        moderngl.init_context()
        self.ctx = moderngl.get_context()
        self.imgui_ctx = imgui.create_context()
        imgui.set_current_context(self.imgui_ctx)  # create_context keeps an earlier one current
        io = imgui.get_io()
        io.set_ini_filename("")
        io.config_windows_move_from_title_bar_only = True
        if os.path.exists(FONT):
            io.fonts.add_font_from_file_ttf(FONT, 15.0)
        imgui.style_colors_dark()
        self.gui = ImGuiRenderer(self.ctx)
        self.input = _Input(self.win)
        self.win.push_handlers(self.input)
        self.win.push_handlers(on_close=self._on_close)
        self.app = App()
        self.files = self.app.files = Files(self.app, self)  # dialogs, recent files, drops, Reload art
        self.win.push_handlers(on_file_drop=self.files.on_drop)
        self.canvas = CanvasRenderer(self.ctx)
        self.thumbs = Thumbs(self.ctx, self.gui)
        self.panels = Panels(self.app, self.thumbs)
        self.timeline_panel = TimelinePanel(self.app)
        self.ghosts = GhostRenderer(self.ctx, self.canvas.compositor)
        self.ready = ready
        self.autosave_interval = autosave_interval
        self._ready_sent = False
        self._gesture = None
        self._last = time.perf_counter()
        self._autosaved_at = time.monotonic()
        self._autosaved_version = -1
        self._caption = ""
        self.frames = 0
        self.frame_ms = 0.0
        self.closed = False
        self._then = None  # what to do once a dialog's jobs have run
        self._settle = 3
        self._last_frame = 0.0
        self._expect_scene = path is not None
        self._rects_file = os.environ.get("PUPPET_APP_RECTS") or None
        if path is not None:
            self.open_scene(path)

    # -- files and dialogs ------------------------------------------------------------
    def open_scene(self, path: str, *, discard: bool = False) -> None:
        """Open ``path``, asking first about unsaved changes (unless ``discard``: the user
        chose "Don't save") and about a newer autosave. The open scene stays until the new
        one has loaded: a file that fails to open changes nothing."""
        app = self.app
        if app.snap.loaded and app.snap.dirty and not discard:
            app.dialog, app.after_dialog = "unsaved", ("open", path)
            return
        pending = autosave.pending(scene_file(path)) if os.path.isfile(path) else None
        if pending:
            app.recover_path, app.path_field = pending, path
            app.dialog = "recover"
            return
        self.files.reopening()
        app.open(path)

    def recover(self, yes: bool) -> None:
        app = self.app
        path, auto = app.path_field, app.recover_path
        app.dialog = None
        if yes:
            app.open(path, recover_from=auto)
        else:
            autosave.remove(os.path.abspath(path))
            app.open(path)

    def open_dialog(self, kind: str) -> None:
        """File > Open / Save As: the native dialog (:mod:`puppet.app.ui.files`), else the path field."""
        app = self.app
        then = self.open_scene if kind == "open" else \
            (lambda p: app.save(p if p.lower().endswith(".json") else p + ".json"))
        default = (app.snap.file or os.getcwd() + os.sep) if kind == "save_as" else (
            os.path.dirname(app.snap.file) + os.sep if app.snap.file else os.getcwd() + os.sep)
        if self.files.ask(kind, then, default):
            return
        app.dialog, app.path_field = kind, default

    def proceed(self, after, require_saved: bool = False) -> None:
        """Go on after the unsaved-changes dialog: quit, or open ``("open", path)``; with
        ``require_saved`` only once the save posted before has succeeded."""
        def go(saved: bool) -> None:
            if require_saved and not saved:
                return  # the save failed: stay (its error is on the status line)
            self._then = after
        self.app.after_jobs(go)

    def _on_close(self):
        self.app.request_quit()
        return True  # the app decides (unsaved changes)

    # -- one frame --------------------------------------------------------------------
    def frame(self, dispatch: bool = True) -> None:
        """Handle pending input and draw one frame."""
        t0 = time.perf_counter()
        win, app = self.win, self.app
        win.switch_to()
        imgui.set_current_context(self.imgui_ctx)  # several windows may live in one process
        if dispatch:
            win.dispatch_events()
        self._follow_up()
        self.files.poll()
        app.timeline.tick()
        app.sync()
        if app.title != self._caption:
            self._caption = app.title
            win.set_caption(self._caption)
        io = imgui.get_io()
        w, h = win.get_size()
        fb = win.get_framebuffer_size()
        io.display_size = imgui.ImVec2(w, h)
        io.display_framebuffer_scale = imgui.ImVec2(fb[0] / max(w, 1), fb[1] / max(h, 1))
        io.delta_time = max(t0 - self._last, 1e-4)
        self._last = t0
        imgui.new_frame()
        top = menus.menu_bar(app, self)
        rows = 2 if self._toolbar_width > w else 1  # the toolbar wraps in a narrow window
        tool_h = rows * imgui.get_frame_height() + (rows - 1) * imgui.get_style().item_spacing.y \
            + 2 * imgui.get_style().window_padding.y
        status_h = imgui.get_frame_height() + 2 * imgui.get_style().window_padding.y
        imgui.set_next_window_pos(imgui.ImVec2(0, top))
        imgui.set_next_window_size(imgui.ImVec2(w, tool_h))
        imgui.begin("##toolbar", None, FIXED)
        self._toolbar_width = menus.toolbar(app, wrap=rows == 2)
        settled = (rows == 2) == (self._toolbar_width > w)  # else the toolbar's rows change next frame
        imgui.end()
        body = h - top - tool_h - status_h
        panel = self.timeline_panel  # its height is dragged by its top edge; the canvas keeps >= 120 px
        # whole pixels: a fractional canvas area left a stray row of the picture above it
        panel.height = float(round(min(max(panel.natural_height(body), TIMELINE_MIN), max(body - 120.0, TIMELINE_MIN))))
        tl_h = panel.height if app.snap.loaded else 0
        side = panel_width(w)
        imgui.set_next_window_pos(imgui.ImVec2(w - side, top + tool_h))
        imgui.set_next_window_size(imgui.ImVec2(side, body))
        imgui.begin("##panels", None, FIXED)
        self.panels.draw()
        imgui.end()
        app.set_area((0.0, top + tool_h, w - side, body - tl_h))
        cursor = self._canvas_window()
        if tl_h:
            self.timeline_panel.window((0, h - status_h - tl_h, w - side, tl_h), FIXED)
        imgui.set_next_window_pos(imgui.ImVec2(0, h - status_h))
        imgui.set_next_window_size(imgui.ImVec2(w, status_h))
        imgui.begin("##status", None, FIXED)
        menus.status_line(app, cursor)
        imgui.end()
        actions.handle_keys(app, self)
        self.input.chars = ""
        startpage.draw(self)
        menus.dialogs(app, self)
        menus.help_overlay(app)
        imgui.render()
        ctx = self.ctx
        ctx.error  # a stale flag would make the next GL call fail
        ctx.screen.use()
        ctx.viewport = (0, 0, fb[0], fb[1])
        self.canvas.fast = app.timeline.playing  # frames come and go: composite them smaller
        self.canvas.draw(app.snap, app.view, app.area, (w, h), hidden=app.hidden, depth_view=app.depth_view,
                         wireframe=app.show_mesh, fb_height=fb[1], tint=app.script.tint(app),
                         under=self.ghosts.under(app) if app.snap.ghosts and app.timeline.onion_on else None)
        self.gui.render(imgui.get_draw_data(), fb)
        win.flip()
        self.frames += 1
        self.frame_ms = (time.perf_counter() - t0) * 1000
        if self._rects_file:
            self._dump_rects()
        self._autosave()
        if not self._ready_sent and settled and (app.snap.loaded or not self._expect_scene or app.dialog == "recover"):
            self._ready_sent = True
            if self.ready is not None:
                x, y, cw, ch = app.view.canvas_rect(app.snap.canvas) if app.snap.loaded else (0, 0, 0, 0)
                self.ready({"canvas": [x, y, cw, ch], "scale": app.view.scale, "window": [w, h],
                            "file": app.snap.file})

    def _dump_rects(self) -> None:
        """Where the widgets, the canvas, the pins and the timeline are (``PUPPET_APP_RECTS=FILE``:
        end-to-end tests and the benchmark under X find them with it), written atomically a
        few times a second."""
        now = time.monotonic()
        if now - getattr(self, "_rects_at", 0.0) < 0.2:
            return
        self._rects_at = now
        app = self.app
        markers = {m.name: [float(v) for v in app.view.to_screen(app.marker_xy(m))] for m in app.markers()}
        info = {"rects": RECTS, "scale": app.view.scale, "origin": list(app.view.origin),
                "step": app.script.step, "mode": app.mode, "busy": app.busy, "version": app.snap.version,
                "status": app.status.text if app.status else "", "area": list(app.area), "markers": markers,
                "timeline": getattr(self.timeline_panel, "area", None), "time": app.snap.time}
        tmp = self._rects_file + ".tmp"
        with open(tmp, "w") as f:
            json.dump(info, f)
        os.replace(tmp, self._rects_file)

    def _canvas_window(self):
        """The canvas area: an invisible button that takes the pointer (so a click on a
        panel never reaches the canvas), the tools, and the overlay. Returns the cursor's
        canvas position when it is over the canvas."""
        app = self.app
        x, y, w, h = app.area
        imgui.set_next_window_pos(imgui.ImVec2(x, y))
        imgui.set_next_window_size(imgui.ImVec2(w, h))
        imgui.push_style_var(imgui.StyleVar_.window_padding, imgui.ImVec2(0, 0))
        imgui.begin("##canvas", None, FIXED | imgui.WindowFlags_.no_background | imgui.WindowFlags_.no_scrollbar
                    | imgui.WindowFlags_.no_scroll_with_mouse)
        imgui.invisible_button("canvas", imgui.ImVec2(max(w, 1), max(h, 1)),
                               imgui.ButtonFlags_.mouse_button_left | imgui.ButtonFlags_.mouse_button_right
                               | imgui.ButtonFlags_.mouse_button_middle)
        io = imgui.get_io()
        pos = (float(io.mouse_pos.x), float(io.mouse_pos.y))
        hovered = imgui.is_item_hovered()
        if imgui.is_item_activated() and app.snap.loaded:
            button = next((b for b in (0, 2, 1) if imgui.is_mouse_clicked(b)), 0)
            ev = self._event("press", pos, button)
            tool = choose_tool(app, ev, imgui.is_key_down(imgui.Key.space))
            self._gesture = tool(app, ev) if tool else None
            self._send(None)
        elif self._gesture is not None and imgui.is_item_active() and (io.mouse_delta.x or io.mouse_delta.y):
            self._send(self._event("drag", pos))
        if self._gesture is not None and imgui.is_item_deactivated():
            self._send(self._event("release", pos))
            if self._gesture is not None:
                self._gesture.close()
                self._gesture = None
        if hovered and io.mouse_wheel:
            app.zoom(pos, io.mouse_wheel)
        dl = imgui.get_window_draw_list()
        if app.snap.loaded:
            script.draw_overlay(dl, app)
            deform_overlay.draw_overlay(dl, app)
            if app.show_links:
                overlay.draw_links(dl, app)
            if app.show_pins:
                hover = app.marker_at(pos) if hovered and self._gesture is None else None
                overlay.draw_pins(dl, app, hover)
            if app.depth_view:
                overlay.draw_depth_legend(dl, app, *depth_range(app.snap.layers))
        imgui.end()
        imgui.pop_style_var()
        return tuple(app.view.to_canvas(pos)) if hovered and app.snap.loaded else None

    def gesture_held(self) -> bool:
        """A canvas gesture is running or a mouse button is down (keys that change the mode
        or the pose wait)."""
        return self._gesture is not None or any(imgui.is_mouse_down(b) for b in range(3))

    def cancel_gesture(self) -> None:
        """Esc / Ctrl+Z during a drag: the gesture ends and nothing it did stays."""
        g, self._gesture = self._gesture, None
        if g is not None:
            g.close()  # the tool's finally blocks run
            self.app.cancel_gesture()

    def _event(self, kind, pos, button=0) -> CanvasEvent:
        io = imgui.get_io()
        xy = self.app.view.to_canvas(pos)
        return CanvasEvent(kind, pos, (float(xy[0]), float(xy[1])), button, io.key_shift, io.key_ctrl, io.key_alt)

    def _send(self, ev) -> None:
        try:
            if ev is None:
                next(self._gesture)
            else:
                self._gesture.send(ev)
        except StopIteration:
            self._gesture = None

    def _follow_up(self) -> None:
        then = self._then
        if then is None:
            return
        self._then = None
        if then == "quit":
            self.app.quit_now = True
        elif isinstance(then, tuple) and then[0] == "open":
            self.open_scene(then[1], discard=True)

    def _autosave(self) -> None:
        snap = self.app.snap
        now = time.monotonic()
        if now - self._autosaved_at < self.autosave_interval:
            return
        self._autosaved_at = now
        if snap.loaded and snap.dirty and snap.version != self._autosaved_version:
            self._autosaved_version = snap.version
            self.app.autosave()

    # -- the loop ---------------------------------------------------------------------
    def step(self) -> bool:
        """One turn of the loop: take input, and draw a frame when something changed: at
        once for a new snapshot, for input at most :data:`MAX_FPS` times a second, a few
        frames after activity (ImGui settles), and a few a second when idle. True when it
        drew."""
        now = time.perf_counter()
        self.win.switch_to()
        self.win.dispatch_events()
        touched, self.input.touched = self.input.touched, False
        # ImGui takes queued input a few events a frame (a fast key press and release land in
        # different frames): keep drawing until its queue is empty, or typed text lags
        touched = touched or self.imgui_ctx.input_events_queue.size() > 0
        app = self.app
        new = app.news
        if (app.timeline.playing or app.timeline.recording is not None) and \
                now - self._last_frame >= 1.0 / PLAY_FPS:
            touched = True  # the playhead moves
        if touched or new:
            self._settle = 3
        gap = now - self._last_frame
        fps = DRAG_FPS if self._gesture is not None and app.busy else MAX_FPS
        due = new or (self._settle > 0 and gap >= 1.0 / fps) or gap > 0.25
        if not due:
            return False
        self._settle -= 1
        self._last_frame = now
        self.frame(dispatch=False)
        return True

    def run(self) -> None:
        """Run :meth:`step` until the app quits (a turn every few ms: a new snapshot is shown
        as soon as it is published; frames themselves are paced by :meth:`step`)."""
        ended = False
        try:
            while not self.app.quit_now:
                if not self.step():
                    time.sleep(0.004)
            ended = True
        finally:
            self.close(keep_autosave=not ended)

    def close(self, *, keep_autosave: bool = False) -> None:
        """Finish pending jobs (a save), remove the autosave, release GL and the window.
        ``keep_autosave``: the loop did not end normally (an exception, Ctrl+C): unsaved
        changes stay in the autosave, said on stderr."""
        if self.closed:
            return
        self.closed = True
        self.files.cancel()
        kept = self.app.shutdown(keep_autosave=keep_autosave)
        if kept:
            print(f"puppet app: unsaved changes kept in {kept} (opening the scene offers them)", file=sys.stderr)
        self.win.switch_to()
        imgui.set_current_context(self.imgui_ctx)
        self.thumbs.release()
        self.ghosts.release()
        self.canvas.release()
        self.gui.release()
        imgui.destroy_context(self.imgui_ctx)
        self.win.close()


def print_ready(info: dict) -> None:
    """The ready line on stdout (tests wait for it before sending input)."""
    print("puppet app: ready " + json.dumps(info), flush=True)
    sys.stdout.flush()
