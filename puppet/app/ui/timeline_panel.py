"""The timeline panel at the bottom of the window (Dear ImGui): transport (play / pause /
loop, frame and key steps), Key, Record with its speed and smoothing, fps and length,
onion skin settings, the selected keys' ease; below, the ruler with the playhead and one
row of marks for pose keys and one per keyed pin.

Click or drag on the ruler or an empty part of a row to scrub; click a mark to select its
key (Shift adds), drag it to move the key (Ctrl + drag copies it); Delete, Ctrl+C and
Ctrl+V act on the selected keys after a click in the timeline.
"""
from __future__ import annotations

from imgui_bundle import imgui

from puppet.app.model import onion
from puppet.app.model import timeline as tl
from puppet.app.model.record import SPEEDS
from puppet.app.ui.overlay import col
from puppet.app.ui.widgets import button, note, toggle

HEIGHT = 200  # window pixels, at first (the top edge drags it)
MIN_HEIGHT = 110  # the transport, the selection bar and the ruler with a row
SHARE = 0.3  # at most this share of the height under the toolbar, until the user drags it
GRIP = 6  # the draggable top edge
LABELS = 120  # width of the row labels
RULER = 20
ROW = 18
MARK = 5.0  # half size of a key mark
#: mark colours by ease (the ease of the segment ending at the key)
EASE_COLOURS = {"linear": (0.85, 0.85, 0.9, 1.0), "smooth": (0.45, 0.8, 1.0, 1.0),
                "step": (0.95, 0.7, 0.3, 1.0), "bezier": (0.7, 0.55, 1.0, 1.0)}
SELECTED = (1.0, 0.3, 0.25, 1.0)
PLAYHEAD = (1.0, 0.25, 0.2, 1.0)
ONION = ("keys", "frames")


class TimelinePanel:
    """Draws ``app.timeline`` and turns clicks into its actions."""

    def __init__(self, app):
        self.app = app
        self._press = None  # (kind "scrub" | "key", press x, press time, key times)
        self._drag_dt = 0.0
        self.fps_field = 24.0
        self.height = float(HEIGHT)  # dragged by the top edge (see resize_grip)
        self.dragged = False  # the user set the height (else it follows the window: natural_height)

    def natural_height(self, body: float) -> float:
        """Its height in a body (window height under the toolbar) of ``body`` pixels:
        :data:`HEIGHT`, at most :data:`SHARE` of the body (a small window keeps its canvas),
        at least :data:`MIN_HEIGHT`; what the user dragged it to once they did."""
        return self.height if self.dragged else float(max(MIN_HEIGHT, min(HEIGHT, round(SHARE * body))))

    @property
    def tl(self) -> tl.Timeline:
        return self.app.timeline

    def window(self, rect, flags) -> None:
        """The panel in its own fixed window at ``rect`` (x, y, w, h)."""
        imgui.set_next_window_pos(imgui.ImVec2(rect[0], rect[1]))
        imgui.set_next_window_size(imgui.ImVec2(rect[2], rect[3]))
        imgui.begin("##timeline", None, flags | imgui.WindowFlags_.no_scrollbar)
        self.resize_grip(rect[2])
        self.draw()
        imgui.end()

    def resize_grip(self, width: float) -> None:
        """The timeline's top edge: drag it up or down to give the rows more or less room
        (the window clamps :attr:`height`)."""
        imgui.set_cursor_pos(imgui.ImVec2(0, 0))
        imgui.invisible_button("##timeline-grip", imgui.ImVec2(max(width, 1), GRIP))
        imgui.set_item_tooltip("drag to make the timeline taller or shorter")
        note("timeline:grip")
        if imgui.is_item_active():
            self.height -= imgui.get_io().mouse_delta.y
            self.dragged = True
        lit = imgui.is_item_hovered() or imgui.is_item_active()
        a, b = imgui.get_item_rect_min(), imgui.get_item_rect_max()
        imgui.get_window_draw_list().add_rect_filled(a, imgui.ImVec2(b.x, a.y + (3 if lit else 1)),
                                                     col((0.45, 0.65, 1.0, 0.9) if lit else (1, 1, 1, 0.15)))

    def draw(self) -> None:
        if not self.app.snap.loaded:
            return
        self.transport()
        self.selection_bar()
        self.tracks()
        if imgui.is_window_hovered(imgui.HoveredFlags_.child_windows) and imgui.is_mouse_clicked(0):
            self.tl.focus = True

    # -- controls -------------------------------------------------------------------------
    def transport(self) -> None:
        t = self.tl
        if button("|<", "to the first key (Home of the timeline)"):
            t.playing = False
            t.scrub(min(onion.key_times(t.anim), default=0.0))
        imgui.same_line()
        if button("<", "previous frame (,)"):
            t.step_frame(-1)
        imgui.same_line()
        if button("Pause" if t.playing else "Play", "play / pause the animation from the playhead (P)"):
            t.toggle_play()
        note("Play")
        imgui.same_line()
        if button(">", "next frame (.)"):
            t.step_frame(1)
        imgui.same_line()
        if button(">|", "to the last key"):
            t.playing = False
            t.scrub(t.duration())
        imgui.same_line()
        t.loop = toggle("loop", t.loop, "play again from the first key at the end")
        imgui.same_line()
        imgui.text("|")
        imgui.same_line()
        if button("Key", "store the pose at the playhead (K): the active pose, or every pin as the canvas shows it"):
            t.add_key()
        imgui.same_line()
        rec = t.record
        if rec:
            imgui.push_style_color(imgui.Col_.button, imgui.ImVec4(0.75, 0.15, 0.12, 1.0))
        if button("Record", "record mode (Puppet Sketch): drag a pin and its motion is recorded in real time "
                  "from the playhead, then simplified into keys"):
            t.record = not t.record
            if t.record:
                self.app.set_mode("pose")
                self.app.say("Record on: drag a pin to record its motion from the playhead")
        if rec:
            imgui.pop_style_color()
        imgui.same_line()
        imgui.set_next_item_width(60)
        i = SPEEDS.index(t.speed) if t.speed in SPEEDS else 1
        changed, i = imgui.combo("speed", i, [f"{s:g}x" for s in SPEEDS])
        imgui.set_item_tooltip("record speed: how fast the playhead runs while you record (0.5x: slow motion, "
                               "the motion plays back twice as fast as you dragged)")
        note("combo:speed")
        if changed:
            t.speed = SPEEDS[i]
        imgui.same_line()
        imgui.set_next_item_width(70)
        _, t.tolerance = imgui.drag_float("smooth", t.tolerance, 0.1, 0.0, 50.0, "%.1f px")
        imgui.set_item_tooltip("smoothing of a recording: the keys replay the dragged path within this many "
                               "canvas pixels (more: fewer keys)")
        imgui.set_next_item_width(70)
        fps_now = t.fps
        if not getattr(self, "_fps_editing", False):
            self.fps_field = fps_now
        changed, self.fps_field = imgui.input_float("fps", self.fps_field, 0, 0, "%g",
                                                    imgui.InputTextFlags_.enter_returns_true)
        self._fps_editing = imgui.is_item_active()
        imgui.set_item_tooltip("frames per second of the animation (Enter applies; saved in the scene)")
        note("fps")
        if changed and self.fps_field != fps_now:
            if t.anim is None:
                self.app.say("add a key first (K): the fps belongs to the animation", "error")
            else:
                t.set_fps(self.fps_field)
        imgui.same_line()
        imgui.set_next_item_width(60)
        changed, length = imgui.input_float("view", t.length, 0, 0, "%g s")
        imgui.set_item_tooltip("seconds the timeline shows at least (it widens past the last key; "
                               f"the animation ends at its last key: {t.duration():g} s now)")
        if changed and length > 0:
            t.length = min(float(length), 3600.0)
        imgui.same_line()
        imgui.text("|")
        imgui.same_line()
        on = toggle("onion", t.onion_on, "onion skin: the keys (or frames) before in red and after in green, "
                    "ghosted behind the current frame")
        if on != t.onion_on:
            t.onion_on = on
            t._push()
        imgui.same_line()
        imgui.set_next_item_width(70)
        changed, i = imgui.combo("##onion-mode", ONION.index(t.onion["mode"]), list(ONION))
        imgui.set_item_tooltip("ghost the neighbouring keys, or the neighbouring frames")
        if changed:
            t.onion["mode"] = ONION[i]
            t._push()
        imgui.same_line()
        imgui.set_next_item_width(50)
        changed, n = imgui.input_int("##onion-count", int(t.onion["count"]), 0)
        imgui.set_item_tooltip("how many keys (or frames) each side")
        if changed:
            t.onion["count"] = max(1, min(int(n), 8))
            t._push()
        imgui.same_line()
        imgui.set_next_item_width(70)
        changed, op = imgui.slider_float("##onion-opacity", float(t.onion["opacity"]), 0.05, 1.0, "%.2f")
        imgui.set_item_tooltip("opacity of the nearest ghosts")
        if changed:
            t.onion["opacity"] = op  # drawn on the GL thread: no solve needed

    def selection_bar(self) -> None:
        t = self.tl
        imgui.align_text_to_frame_padding()  # the same height with or without the key widgets
        imgui.text(f"{t.time:6.2f} s  frame {round(t.time * t.fps):d}")
        imgui.same_line()
        imgui.text_disabled("(showing the animation)" if t.showing and self.app.mode == "pose" else
                            "(showing the pose)")
        keys = [k for k in t.keys() if any(tl.same(k["time"], s) for s in t.selected)]
        n = t.frame_total()  # (drawn every frame: no list of times)
        if t.showing and t.prefetch and n:
            done = min(self.app.cached_frames(), n)
            if done < n:
                imgui.same_line()
                imgui.text_disabled(f" solving frames {done}/{n}")
        if t.recording is not None:
            imgui.same_line()
            imgui.text_colored(imgui.ImVec4(1, 0.3, 0.25, 1), "  REC")
        if not keys:
            return
        imgui.same_line()
        imgui.text("|")
        imgui.same_line()
        what = f"key {keys[0]['time']:g} s" if len(keys) == 1 else f"{len(keys)} keys"
        extra = len(tl.key_pins(keys[0])) if len(keys) == 1 and "pose" in keys[0] else 0
        imgui.text(what + (f" ({keys[0]['pose']}" + (f" + {extra} pins" if extra else "") + ")"
                           if len(keys) == 1 and "pose" in keys[0] else ""))
        imgui.same_line()
        ease = keys[0].get("ease", "linear")
        imgui.set_next_item_width(90)
        changed, i = imgui.combo("ease", tl.EASES.index(ease), list(tl.EASES))
        imgui.set_item_tooltip("how the segment that ends at this key eases in")
        note("combo:ease")
        if changed:
            t.set_ease(tl.EASES[i], keys[0].get("curve"))
        if ease == "bezier":
            imgui.same_line()
            imgui.set_next_item_width(200)
            curve = [float(c) for c in keys[0].get("curve", tl.DEFAULT_CURVE)]
            changed, curve = imgui.drag_float4("curve", curve, 0.01, -2.0, 2.0, "%.2f")
            imgui.set_item_tooltip("bezier control points cx1, cy1, cx2, cy2 (x in 0..1)")
            if changed:
                curve[0], curve[2] = min(max(curve[0], 0.0), 1.0), min(max(curve[2], 0.0), 1.0)
                t.set_ease("bezier", curve)
        imgui.same_line()
        if button("Copy", "copy the selected keys (Ctrl+C)"):
            t.copy()
        imgui.same_line()
        if button("Paste", "paste copied keys at the playhead (Ctrl+V)", enabled=bool(t.clipboard)):
            t.paste()
        imgui.same_line()
        if button("Delete key", "delete the selected keys (Delete)"):
            t.delete_keys()

    # -- the tracks -----------------------------------------------------------------------
    def rows(self) -> list[tuple[str, str | None]]:
        """(label, pin) for each row: pose keys (pin None), then each keyed pin."""
        keyed = {n for k in self.tl.keys() for n in tl.key_pins(k)}  # pins keys and pose keys' overrides
        order = [p.name for p in self.app.snap.data.pins] if self.app.snap.loaded else []
        pins = [n for n in order if n in keyed] + sorted(keyed - set(order))
        return [("poses", None)] + [(n, n) for n in pins]

    def tracks(self) -> None:
        t = self.tl
        avail = imgui.get_content_region_avail()
        imgui.begin_child("##tracks", imgui.ImVec2(avail.x, max(avail.y, RULER + ROW)), 0)
        rows = self.rows()
        p0 = imgui.get_cursor_screen_pos()
        width = imgui.get_content_region_avail().x
        x0, x1 = p0.x + LABELS, p0.x + width - 10
        span = t.span()
        scale = (x1 - x0) / span

        def tx(time):
            return x0 + time * scale

        height = RULER + ROW * len(rows)
        imgui.invisible_button("##track-area", imgui.ImVec2(max(width, 1), height))
        note("timeline")
        self.area = {"x0": x0, "x1": x1, "y0": p0.y, "span": span, "ruler": RULER, "row": ROW,
                     "rows": [r[0] for r in rows]}
        self._input(rows, tx, scale, p0)
        dl = imgui.get_window_draw_list()
        dl.add_rect_filled(imgui.ImVec2(x0, p0.y), imgui.ImVec2(x1, p0.y + RULER), col((0.2, 0.2, 0.23, 1)))
        step = tl.ruler_step(scale)
        k = 0
        while k * step <= span + 1e-9:
            x = tx(k * step)
            dl.add_line(imgui.ImVec2(x, p0.y + RULER - 6), imgui.ImVec2(x, p0.y + height), col((1, 1, 1, 0.12)))
            dl.add_text(imgui.ImVec2(x + 2, p0.y + 2), col((0.8, 0.8, 0.85, 1)), f"{k * step:g}")
            k += 1
        end = t.duration()
        if t.keys():
            dl.add_rect_filled(imgui.ImVec2(tx(float(t.keys()[0]["time"])), p0.y + RULER - 3),
                               imgui.ImVec2(tx(end), p0.y + RULER), col((0.3, 0.6, 1.0, 0.8)))
        moving = self._press is not None and self._press[0] == "key"
        for r, (label, pin) in enumerate(rows):
            y = p0.y + RULER + r * ROW
            if r % 2 == 0:
                dl.add_rect_filled(imgui.ImVec2(p0.x, y), imgui.ImVec2(x1, y + ROW), col((1, 1, 1, 0.04)))
            dl.add_text(imgui.ImVec2(p0.x + 4, y + 1), col((0.85, 0.85, 0.85, 1)), label[:16])
            for key in t.keys():
                if not tl.in_row(key, pin):
                    continue
                kt = float(key["time"])
                sel = any(tl.same(kt, s) for s in t.selected)
                c = col(SELECTED if sel else EASE_COLOURS.get(key.get("ease", "linear"), EASE_COLOURS["linear"]))
                self._mark(dl, tx(kt), y + ROW / 2, c, key.get("ease", "linear"))
                if sel and moving and self._drag_dt:
                    self._mark(dl, tx(t.snap_time(kt + self._drag_dt)), y + ROW / 2, col((1, 1, 1, 0.6)),
                               key.get("ease", "linear"))
                if pin is None and not moving:
                    dl.add_text(imgui.ImVec2(tx(kt) + MARK + 2, y + 1), col((0.7, 0.7, 0.75, 1)),
                                str(key["pose"])[:12])
        x = tx(t.time)
        dl.add_line(imgui.ImVec2(x, p0.y), imgui.ImVec2(x, p0.y + height), col(PLAYHEAD), 2.0)
        dl.add_triangle_filled(imgui.ImVec2(x - 5, p0.y), imgui.ImVec2(x + 5, p0.y), imgui.ImVec2(x, p0.y + 7),
                               col(PLAYHEAD))
        imgui.end_child()

    @staticmethod
    def _mark(dl, x, y, c, ease) -> None:
        r = MARK
        if ease == "step":
            dl.add_rect_filled(imgui.ImVec2(x - r + 1, y - r + 1), imgui.ImVec2(x + r - 1, y + r - 1), c)
        elif ease == "smooth":
            dl.add_circle_filled(imgui.ImVec2(x, y), r - 0.5, c)
        else:
            dl.add_quad_filled(imgui.ImVec2(x, y - r), imgui.ImVec2(x + r, y), imgui.ImVec2(x, y + r),
                               imgui.ImVec2(x - r, y), c)
        dl.add_circle(imgui.ImVec2(x, y), 1.0, col((0, 0, 0, 0.6)))

    def key_under(self, rows, tx, mx, my, y0) -> float | None:
        r = int((my - y0 - RULER) // ROW)
        if my < y0 + RULER or r >= len(rows):
            return None
        pin = rows[r][1]
        best = None
        for key in self.tl.keys():
            if not tl.in_row(key, pin):
                continue
            d = abs(tx(float(key["time"])) - mx)
            if d <= MARK + 2 and (best is None or d < best[0]):
                best = (d, float(key["time"]))
        return None if best is None else best[1]

    def _input(self, rows, tx, scale, p0) -> None:
        t = self.tl
        io = imgui.get_io()
        mx, my = io.mouse_pos.x, io.mouse_pos.y

        def time_at(x):
            return max(0.0, (x - tx(0.0)) / scale)

        if imgui.is_item_activated():
            t.focus = True
            k = self.key_under(rows, tx, mx, my, p0.y)
            if k is not None:
                if io.key_shift:
                    t.selected = [s for s in t.selected if not tl.same(s, k)] if any(
                        tl.same(s, k) for s in t.selected) else t.selected + [k]
                elif not any(tl.same(s, k) for s in t.selected):
                    t.selected = [k]
                self._press = ("key", mx, k, list(t.selected))
                self._drag_dt = 0.0
            else:
                if not io.key_shift:
                    t.selected = []
                t.playing = False
                self._press = ("scrub", mx, time_at(mx), [])
                t.scrub(time_at(mx))
        elif self._press is not None and imgui.is_item_active():
            kind, x_press, t_press, _ = self._press
            if kind == "scrub":
                t.scrub(time_at(mx))
            else:
                self._drag_dt = t.snap_time(t_press + (mx - x_press) / scale) - t.snap_time(t_press)
        if self._press is not None and imgui.is_item_deactivated():
            kind, _, _, times = self._press
            self._press = None
            if kind == "key" and self._drag_dt:
                t.move_keys(times, self._drag_dt, copy=io.key_ctrl)
            self._drag_dt = 0.0
