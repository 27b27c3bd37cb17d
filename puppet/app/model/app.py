"""The app's view state and typed intents, apart from GL and pyglet: the mode, the
selection, the view, the status line; every change of the scene is an intent passed to
the scene session (:mod:`puppet.app.model.session`), the only owner of the document.

The window calls :meth:`App.sync` once a frame (picks up the latest snapshot and status
messages), feeds canvas events to the tools (:mod:`puppet.app.tools.dispatch`) and key presses to
the action table (:mod:`puppet.app.ui.actions`); tools, timeline and panels call the intents
below and never the session itself.
"""
from __future__ import annotations

import math
import os

import numpy as np

from puppet.app.model import autosave, pick
from puppet.app.model.opening import is_picture
from puppet.app.model.session import SceneSession
from puppet.app.model.snapshot import Message, Snapshot
from puppet.app.model.steps import Script, set_step
from puppet.app.model.timeline import Timeline
from puppet.app.model.view import WHEEL_STEP, View

MODES = ("pin", "pose")


class App:
    """Everything the window shows besides pixels; the scene itself lives in the session."""

    def __init__(self, session: SceneSession | None = None):
        self.session = session or SceneSession()
        self.snap: Snapshot = self.session.latest
        self.view = View()
        self.area = (0.0, 0.0, 1.0, 1.0)  # canvas area in the window (x, y, w, h)
        self.mode = "pose"
        self.pin_kind = "interior"  # kind of the pins the Pin tool adds
        self.selection: list[str] = []  # selected pin names, in order
        self.selected_layer: str | None = None
        self.show_pins = True
        self.show_mesh = False
        self.depth_view = False
        self.show_links = False
        self.show_stiffness = False  # the stiffness heat map (puppet.app.tools.deform)
        self.show_cages = False  # layers' cages drawn over them (also while the cage tool is on)
        self.show_help = False
        self.status = Message("Open a scene with File > Open (Ctrl+O)")
        self.overrides: dict[str, tuple[float, float]] = {}  # marker positions during a gesture
        self._overrides_until = 0  # job id whose snapshot ends the overrides
        self.fit_pending = True
        self.quit_now = False
        self.dialog: str | None = None  # "open", "save_as", "unsaved", "recover", "rename_pose"
        self.after_dialog = None  # what a "Don't save" / "Save" in the unsaved dialog goes on with
        self.path_field = ""
        self.recover_path: str | None = None
        self._markers: list[pick.Marker] = []
        self._marker_version = -1
        self._spacing, self._spacing_version = math.inf, -2  # markers' median nearest distance, canvas px
        self._layer_names: dict[str, int] = {}
        self.script = Script()  # the task script's step, tool and drafts
        self.timeline = Timeline(self)  # playhead, keys, record mode, onion skin

    # -- per frame ---------------------------------------------------------------
    def sync(self) -> bool:
        """Take the session's latest snapshot and messages; True when the snapshot changed."""
        snap = self.session.latest
        while self.session.messages:
            self.status = self.session.messages.popleft()
        changed = snap is not self.snap
        if changed:
            file_changed = snap.file != self.snap.file
            self.snap = snap
            if snap.done >= self._overrides_until:
                self.overrides = {}
            if snap.loaded:
                pins = {m.name for m in self.markers()}
                self.selection = [n for n in self.selection if n in pins]
                names = {L.name for L in snap.data.layers}
                if self.selected_layer not in names:
                    self.selected_layer = None
                if file_changed:
                    self.fit_pending = True
        if self.fit_pending and snap.loaded:
            self.fit()
        return changed

    @property
    def title(self) -> str:
        if not self.snap.loaded:
            return "puppet"
        return f"puppet — {os.path.basename(self.snap.file)}" + (" *" if self.snap.dirty else "")

    @property
    def busy(self) -> bool:
        return not self.session.idle()

    @property
    def news(self) -> bool:
        """The session published a snapshot that :meth:`sync` has not taken yet."""
        return self.session.latest is not self.snap

    def shutdown(self, timeout: float = 30.0, *, keep_autosave: bool = False) -> str | None:
        """Let the posted intents run (a save), remove the autosave, stop the session.

        ``keep_autosave`` (the window's loop ended by an exception: Ctrl+C in the terminal,
        a bug): unsaved changes are autosaved once more and the autosave is kept, so the
        next open offers to recover them; returns its path then."""
        session = self.session
        session.wait_idle(timeout)
        kept = None
        if session.scene is not None:
            if not keep_autosave:
                autosave.remove(session.scene.file)
            elif session.latest.dirty:
                session.autosave()
                session.wait_idle(timeout)
                path = autosave.path_for(session.scene.file)
                kept = path if autosave.is_autosave(path) else None
        session.stop()
        return kept

    def say(self, text: str, level: str = "info") -> None:
        self.status = Message(text, level)

    # -- view --------------------------------------------------------------------
    def fit(self) -> None:
        if self.snap.loaded and self.area[2] > 1 and self.area[3] > 1:
            self.view.fit(self.snap.canvas, self.area)
            self.fit_pending = False
            self._fitted = (self.area, self.view.scale, self.view.origin)

    def set_area(self, area) -> None:
        """The canvas area of this frame; a fitted view that nobody zoomed or panned since
        stays fitted when the window is resized."""
        area = tuple(map(float, area))
        fitted = getattr(self, "_fitted", None)
        self.area = area
        if fitted is not None and fitted[0] != area and fitted[1:] == (self.view.scale, self.view.origin):
            self.fit()

    def zoom(self, cursor, notches: float) -> None:
        self.view.zoom_at(cursor, WHEEL_STEP ** notches)

    # -- markers -------------------------------------------------------------------
    def markers(self) -> list[pick.Marker]:
        """Pins and exterior points where the shown pose puts them (cached per snapshot)."""
        if self._marker_version != self.snap.version:
            self._markers = pick.markers(self.snap.data, self.snap.layers) if self.snap.loaded else []
            self._marker_version = self.snap.version
            self._layer_names = {L.name: k for k, L in enumerate(self.snap.data.layers)} if self.snap.loaded else {}
        return self._markers

    def marker_scale(self) -> float:
        """How big the markers are drawn and picked (1: full size; smaller where the view
        puts them closer than :data:`~puppet.app.model.pick.MARKER_SPACING` window px)."""
        ms = self.markers()
        if self._spacing_version != self._marker_version:
            self._spacing = pick.spacing(np.array([m.xy for m in ms]).reshape(-1, 2))
            self._spacing_version = self._marker_version
        return pick.marker_scale(self._spacing, self.view.scale)

    def marker_xy(self, m: pick.Marker) -> tuple[float, float]:
        return self.overrides.get(m.name, m.xy)

    def marker(self, name: str) -> pick.Marker | None:
        return next((m for m in self.markers() if m.name == name), None)

    def posable(self, name: str) -> bool:
        """Pin ``name`` can have a target in a pose (starch pins hold no position)."""
        m = self.marker(name)
        return m is not None and m.kind != "starch"

    def marker_at(self, cursor, radius: float = 9.0, *, starch: bool | None = None) -> pick.Marker | None:
        """The marker under ``cursor`` (window pixels); starch pins only in Pin mode (they
        hold no target), or only them with ``starch=True``."""
        if not self.show_pins:
            return None
        if starch is None:
            ms = [m for m in self.markers() if self.mode == "pin" or m.kind != "starch"]
        else:
            ms = [m for m in self.markers() if (m.kind == "starch") == starch]
        if not ms:
            return None
        pts = self.view.to_screen(np.array([self.marker_xy(m) for m in ms]))
        return pick.marker_at(ms, pts, cursor, max(radius * self.marker_scale(), 4.0))

    def starch_at(self, cursor) -> pick.Marker | None:
        """The starch pin marker under ``cursor`` (window pixels), in any mode."""
        return self.marker_at(cursor, starch=True)

    def layer_index(self, name: str | None) -> int | None:
        self.markers()
        return self._layer_names.get(name)

    @property
    def hidden(self) -> frozenset[str]:
        """The layers the scene hides (``layers[i].visible: false``): posed, not drawn."""
        return frozenset(L.name for L in self.snap.data.layers if not L.visible) if self.snap.loaded else frozenset()

    def hidden_indices(self) -> set[int]:
        return {k for k, L in enumerate(self.snap.data.layers) if not L.visible} if self.snap.loaded else set()

    def select(self, name: str, extend: bool = False) -> None:
        """Select pin ``name`` (Shift: toggle it in the selection)."""
        if extend:
            if name in self.selection:
                self.selection.remove(name)
            else:
                self.selection.append(name)
        elif name not in self.selection:
            self.selection = [name]

    def follow_pointer(self, positions: dict) -> None:
        """Draw markers at ``positions`` (where the pointer has them) whatever snapshots
        arrive, until :meth:`hold_markers` names the job that ends the gesture."""
        self.overrides = dict(positions)
        self._overrides_until = math.inf

    def hold_markers(self, positions: dict, job_id: int) -> None:
        """Show markers at ``positions`` until the snapshot of job ``job_id`` arrives."""
        self.overrides = dict(positions)
        self._overrides_until = job_id

    # -- intents -------------------------------------------------------------------
    def edit(self, fn, *, key: str | None = None) -> int:
        """Run ``fn(scene)`` on the scene thread (an edit; errors go to the status line)."""
        return self.session.edit(fn, key=key)

    def undo(self) -> None:
        self.edit(lambda s: f"undo: {s.history.redo_stack[-1].label}" if s.undo() else "nothing to undo")

    def redo(self) -> None:
        self.edit(lambda s: f"redo: {s.history.undo_stack[-1].label}" if s.redo() else "nothing to redo")

    def jump_history(self, steps: int) -> None:
        """Undo (``steps`` < 0) or redo (> 0) that many steps at once (the History panel)."""
        def fn(s):
            go = s.undo if steps < 0 else s.redo
            n = sum(1 for _ in range(abs(steps)) if go())
            last = (s.history.undo_stack[-1].label if s.history.undo_stack else "the file as opened")
            return f"{'undid' if steps < 0 else 'redid'} {n} step{'s' if n != 1 else ''}: at {last}"
        if steps:
            self.edit(fn)

    def set_mode(self, mode: str) -> None:
        if mode not in MODES or mode == self.mode:
            return
        self.mode = mode
        self.session.show(rest=mode == "pin")

    def show_time(self, t: float | None, onion: dict | None) -> None:
        """The canvas shows the animation at ``t`` (None: the pose) with the onion skin."""
        self.session.show(time=t, onion=onion)

    def prefetch(self, times) -> None:
        self.session.prefetch(times)

    def cached_frames(self) -> int:
        return self.session.cached_frames()

    def build_meshes(self) -> None:
        self.session.build()

    def begin_block(self, key: str, label: str) -> None:
        self.session.begin_block(key, label)

    def end_block(self, key: str) -> int:
        return self.session.end_block(key)

    # -- drags ---------------------------------------------------------------------
    def begin_drag(self, names, *, time: float | None = None, record: bool = False) -> None:
        """Start a drag of pins ``names`` (see :meth:`SceneSession.begin_drag`)."""
        self.session.begin_drag(names, time=time, record=record)

    def move_drag(self, positions: dict, *, time: float | None = None) -> None:
        """The pointer moved the dragged pins to ``positions``: their markers follow at
        once (drawn from the pointer), the canvas when the preview is solved."""
        self.follow_pointer(positions)
        self.session.move_drag(positions, time=time)

    def end_drag(self, positions: dict | None = None, *, keys: dict | None = None,
                 message: str | None = None) -> None:
        """Release: the exact pose (markers held where they were let go until it shows)."""
        self.hold_markers(self.overrides, self.session.end_drag(positions, keys=keys, message=message))

    # -- pins ----------------------------------------------------------------------
    def cancel_gesture(self) -> None:
        """A canvas gesture was cancelled: an open drag ends changing nothing, an open turn
        is taken back (no undo step either way), drafts and held markers go."""
        self.overrides = {}
        self.script.draft = None
        self.session.cancel_block("rotate")
        self.session.end_drag(None)
        self.say("drag cancelled")

    def new_pin_name(self, kind: str | None = None) -> str:
        prefix = "epin" if (kind or self.pin_kind) == "exterior" else "pin"
        names = {m.name for m in self.markers()}
        k = 1
        while f"{prefix}{k}" in names:
            k += 1
        return f"{prefix}{k}"

    def add_pin_at(self, xy) -> str | None:
        """Add a pin where the canvas point ``xy`` is: on the selected layer when the point
        is on its mask (even under other layers), else on the top-most layer there."""
        snap = self.snap
        if not snap.loaded:
            return None
        hidden = self.hidden_indices()
        k = self.layer_index(self.selected_layer)
        at = None
        if self.script.step == "pins":  # the task script: the layer you see there
            hit = pick.layer_at(snap.layers, snap.images, xy, hidden)
            if hit is not None:
                k, at = hit.layer, hit.rest
        if at is None and k is not None and k not in hidden:
            rest = pick.rest_point(snap.layers[k], xy)
            if rest is not None and snap.images[k].contains(rest):
                at = rest
        if at is None:
            hit = pick.layer_at(snap.layers, snap.images, xy, hidden)
            if hit is not None:
                k, at = hit.layer, hit.rest
        if at is None:
            if k is None:
                self.say("no layer under the cursor: click on a layer, or select one in the Layers panel", "error")
                return None
            at = tuple(map(float, xy))  # the selected layer; the scene says if the point is not allowed
        name, kind = self.new_pin_name(), self.pin_kind
        layer = snap.data.layers[k].name
        self.selected_layer = layer
        self.edit(lambda s: s.add_pin(name, layer, at, kind=kind))
        self.selection = [name]
        return name

    def remove_pins(self, names) -> None:
        names = [n for n in names if (m := self.marker(n)) is not None and m.kind != "auto"]
        if not names:
            self.say("automatic exterior points cannot be removed (turn the layer's exterior off)", "error")
            return

        def fn(s):
            with s.block("remove pins" if len(names) > 1 else f"remove pin {names[0]}"):
                for n in names:
                    s.remove_pin(n)
        self.edit(fn)
        self.selection = [n for n in self.selection if n not in names]

    def move_pins(self, positions: dict) -> None:
        """Move pins' rest positions (Pin mode); one undo step; nothing moves if one cannot."""
        if not positions:
            return

        def fn(s):
            before = s.to_dict()
            try:
                with s.block("move pins" if len(positions) > 1 else f"move pin {next(iter(positions))}"):
                    for n, xy in positions.items():
                        s.move_pin(n, xy)
            except Exception:
                if s.to_dict() != before:
                    s.undo()
                raise
        self.hold_markers(positions, self.edit(fn))

    def set_targets(self, positions: dict, label: str = "move pins") -> None:
        """Targets of pins in the active pose (Pose mode); one undo step."""
        def fn(s):
            with s.block(label):
                for n, xy in positions.items():
                    s.set_target(n, xy)
        self.hold_markers(positions, self.edit(fn))

    def nudge(self, dx: float, dy: float) -> None:
        names = [n for n in self.selection if self.marker(n) is not None]
        if not names:
            return
        base = {n: self.marker_xy(self.marker(n)) for n in names}  # held positions of earlier nudges
        pos = {n: (xy[0] + dx, xy[1] + dy) for n, xy in base.items()}
        if self.mode == "pin":
            self.move_pins({n: xy for n, xy in pos.items() if self.marker(n).kind != "auto"})
        else:
            self.set_targets({n: xy for n, xy in pos.items() if self.posable(n)}, "nudge pins")

    def change_depth(self, delta: float) -> None:
        """``]`` / ``[``: pins' depth (Pin mode) or their depth in the pose (Pose mode)."""
        pin_mode = self.mode == "pin"
        names = [n for n in self.selection if (m := self.marker(n)) is not None and m.kind != "auto"
                 and (pin_mode or m.kind != "starch")]
        if not names:
            self.say("select pins first (click a pin; Shift-click adds)", "error")
            return

        def fn(s):  # from the scene as it is when the job runs (keys may come faster than frames)
            rest = {p.name: p.depth for p in s.data.pins}
            with s.block("pin depth"):
                for n in names:
                    if pin_mode:
                        s.set_pin(n, depth=rest[n] + delta)
                    else:
                        t = s.data.poses.get(s.active_pose, {}).get(n)
                        base = t.depth if t is not None and t.depth is not None else rest[n]
                        s.set_target(n, depth=base + delta)
            d = [p.depth for p in s.data.pins if p.name in names] if pin_mode else \
                [s.data.poses[s.active_pose][n].depth for n in names]
            return "depth " + ", ".join(f"{n} {v:g}" for n, v in zip(names, d))
        self.edit(fn)

    def target_angle(self, name: str) -> float:
        t = self.snap.data.poses.get(self.snap.active, {}).get(name) if self.snap.loaded else None
        return float(t.angle) if t is not None else 0.0

    # -- files ---------------------------------------------------------------------
    def open(self, path: str, *, recover_from: str | None = None) -> None:
        """Open a scene, or a picture as a new scene (or an autosave ``recover_from`` in
        its place), on the scene thread."""
        path = os.path.abspath(os.path.expanduser(path))
        picture = is_picture(path)
        self.selection, self.selected_layer = [], None
        self.script = Script()
        self.timeline.reset()
        self.mode = "pin" if picture else "pose"  # as the command line opens it, whatever was open before
        if picture:
            set_step(self, "image")
        self.session.open(path, picture=picture, recover_from=recover_from, rest=self.mode == "pin")

    def save(self, path: str | None = None) -> None:
        """Save to the scene's file (or ``path``: Save As), atomically."""
        if self.snap.loaded:
            self.session.save(os.path.abspath(os.path.expanduser(path)) if path else None)

    def close_scene(self) -> None:
        self.session.close_scene()

    def autosave(self) -> None:
        self.session.autosave()

    def write_copy(self, folder: str, then) -> None:
        """The scene as it is now written to ``folder/scene.json``; ``then(path)`` on the
        scene thread (see :meth:`SceneSession.write_copy`)."""
        self.session.write_copy(folder, then)

    def after_jobs(self, fn) -> None:
        """``fn(saved)`` once the intents posted before have run."""
        self.session.after(fn)

    def request_quit(self) -> None:
        if self.snap.loaded and self.snap.dirty:
            self.dialog, self.after_dialog = "unsaved", "quit"
        else:
            self.quit_now = True
