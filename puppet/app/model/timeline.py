"""The timeline's state and actions (no GL, no ImGui): the playhead, play / pause / loop,
keys (add at the playhead, move, copy, paste, delete, ease), record mode's settings and
the recording under way (the canvas tools that key and record are in
:mod:`puppet.app.tools.anim`), and what the canvas shows (a time, the onion skin: told to
the scene session through the app).

Every edit is an intent run on the scene thread through the Document's key methods
(``set_key``, ``remove_key``, ``move_key``, ``copy_key``, ``set_key_ease``, ``set_fps``);
a gesture (a move of several keys, a recording) is one undo step.
"""
from __future__ import annotations

import math
import time as _time

from puppet.app.model import onion
from puppet.app.model.record import Recording
from puppet.scene.time.timeline import frame_count

EASES = ("linear", "smooth", "step", "bezier")
#: a new bezier ease starts as CSS's "ease"
DEFAULT_CURVE = (0.25, 0.1, 0.25, 1.0)
EPS = 1e-6
#: while recording, a pointer that has not moved for this long (s) is sampled where it rests
REST_SAMPLE = 0.1


def same(a: float, b: float) -> bool:
    return abs(float(a) - float(b)) < EPS


class Timeline:
    """What the timeline panel shows and does for ``app`` (an :class:`~puppet.app.model.app.App`)."""

    def __init__(self, app):
        self.app = app
        self.time = 0.0  # the playhead, seconds
        self.showing = False  # the canvas shows the animation at the playhead (else the active pose)
        self.playing = False
        self.loop = True
        self.length = 2.0  # seconds the ruler shows at least (app only)
        self.selected: list[float] = []  # times of the selected keys
        self.clipboard: list[dict] = []  # copied keys, times relative to the first
        self.record = False  # record mode armed: a pin drag records its motion
        self.speed = 1.0  # record speed: timeline seconds per second of dragging
        self.tolerance = 3.0  # record smoothing, canvas pixels
        self.onion = dict(onion.DEFAULTS)
        self.onion_on = False
        self.focus = False  # the last click was in the timeline (Delete, Ctrl+C/V act on keys)
        self.clock = _time.monotonic  # real time for playing and recording (tests replace it)
        self.recording: Recording | None = None  # the record gesture under way
        self.last_recording: Recording | None = None
        self._rec_pos: dict = {}
        self._rec_last = 0.0
        self._play = (0.0, 0.0)  # (real time, timeline time) when play started
        self._sent: tuple | None = None
        self._fetched = None  # the animation whose frames were asked for in the background
        self.prefetch = True  # solve the frames ahead of playing (tests that settle turn it off)

    def reset(self) -> None:
        """A new scene: playhead at 0, showing its active pose, nothing selected."""
        self.time, self.showing, self.playing, self.selected = 0.0, False, False, []
        self.recording = None
        self._sent = self._fetched = None
        self._push()

    # -- reading the snapshot ------------------------------------------------------------
    @property
    def anim(self) -> dict | None:
        return self.app.snap.animation if self.app.snap.loaded else None

    @property
    def fps(self) -> float:
        a = self.anim
        return float(a.get("fps", 24)) if a else 24.0

    def keys(self) -> list[dict]:
        a = self.anim
        return list(a.get("keys", [])) if a else []

    def duration(self) -> float:
        ks = self.keys()
        return max((float(k["time"]) for k in ks), default=0.0)

    def span(self) -> float:
        """Seconds the ruler shows: the length setting, past the last key and the playhead."""
        return max(self.length, self.duration() * 1.1, self.time + 0.5, 0.5)

    def snap_time(self, t: float) -> float:
        """``t`` on the nearest frame (1/fps), never negative."""
        f = self.fps
        return max(0.0, round(round(float(t) * f) / f, 6))

    # -- the playhead ---------------------------------------------------------------------
    def scrub(self, t: float, show: bool = True) -> None:
        """Put the playhead at ``t`` (snapped to a frame); the canvas shows that frame."""
        self.time = self.snap_time(t)
        if show:
            self.showing = True
        self._push()

    def leave(self) -> None:
        """The canvas shows the active pose again (a pose was chosen, Pin mode)."""
        self.playing = False
        self.showing = False
        self._push()

    def toggle_play(self) -> None:
        if self.playing:
            self.playing = False
            return
        if not self.keys():
            self.app.say("no keys to play: pose the puppet and press K (Key) first", "error")
            return
        if self.time >= self.duration() - EPS:
            self.time = min(float(self.keys()[0]["time"]), self.duration())
        self.playing, self.showing = True, True
        self._play = (self.clock(), self.time)
        self._push()

    def step_frame(self, n: int) -> None:
        self.playing = False
        self.scrub(self.time + n / self.fps)

    def step_key(self, n: int) -> None:
        times = onion.key_times(self.anim)
        t = self.time
        nxt = [k for k in times if k > t + EPS] if n > 0 else [k for k in reversed(times) if k < t - EPS]
        if nxt:
            self.playing = False
            self.scrub(nxt[0])

    def tick(self, now: float | None = None) -> bool:
        """Advance playback and recording (once a frame); True while something moves."""
        now = self.clock() if now is None else now
        if self.recording is not None:
            # a pointer at rest still records (it holds still); while it moves only its own
            # events count: a sample of the last position at a later time would be a jerk
            if now - self._rec_last >= REST_SAMPLE and self._rec_pos:
                self._rec_last = now
                self.recording.add(now, self._rec_pos)
            self.time = self.recording.time(now)
            return True
        if not self.playing:
            self._push()
            return False
        start, end = (float(self.keys()[0]["time"]), self.duration()) if self.keys() else (0.0, 0.0)
        real0, t0 = self._play
        t = t0 + (now - real0)
        if t > end + EPS:
            if self.loop and end > start:
                t = start + (t - start) % (end - start)
                self._play = (now - (t - start), start)
            else:
                t, self.playing = end, False
        self.time = self.snap_time(t)
        self._push()
        return self.playing

    def _push(self) -> None:
        """Tell the scene thread what to show (time, onion skin) when that changed."""
        show = self.time if self.showing and self.app.mode == "pose" else None
        self._prefetch(show)
        settings = dict(self.onion, fps=self.fps) if self.onion_on else None
        want = (show, None if settings is None else tuple(sorted(settings.items())))
        if want == self._sent:
            return
        self._sent = want
        self.app.show_time(show, settings)

    def frame_total(self) -> int:
        """Frames of the animation, from the first key to the last (0: no keys)."""
        ks = self.keys()
        return frame_count(float(ks[0]["time"]), self.duration(), self.fps) if ks else 0

    def frame_times(self) -> list[float]:
        """Every frame of the animation, from the first key to the last."""
        ks = self.keys()
        t0, f = (float(ks[0]["time"]), self.fps) if ks else (0.0, 1.0)
        return [round(t0 + i / f, 6) for i in range(self.frame_total())]

    def _prefetch(self, show) -> None:
        """Solve the animation's frames in the background (once per scene state) while the
        canvas shows the animation, so that playing does not wait for solves."""
        anim = self.anim
        if show is None or not anim or not self.prefetch or self._fetched == anim:
            return
        self._fetched = anim
        times = self.frame_times()
        k = min(range(len(times)), key=lambda i: abs(times[i] - show)) if times else 0
        self.app.prefetch(times[k:] + times[:k])

    # -- keys -------------------------------------------------------------------------------
    def add_key(self) -> None:
        """Key (K): store what the canvas shows at the playhead: the active pose (as a pose
        key) when it shows a pose, else every pin's target at that time (a pins key)."""
        if self.app.mode != "pose":
            self.app.say("keys are set in Pose mode (2): the canvas shows the rest pose in Pin mode", "error")
            return
        t, showing = self.time, self.showing and self.anim is not None

        def fn(s):
            if showing:
                s.set_key(t, pins=s.pose_at(t))
            else:
                s.set_key(t, s.active_pose)
            return f"key at {t:g} s" + ("" if showing else f" ({s.active_pose})")
        self.app.edit(fn)
        self.selected = [t]
        self.showing = True
        self._push()

    def delete_keys(self, times=None) -> None:
        times = list(self.selected if times is None else times)
        if not times:
            self.app.say("select keys first (click a mark in the timeline)", "error")
            return

        def fn(s):
            with s.block("delete keys" if len(times) > 1 else f"delete key at {times[0]:g} s"):
                for t in times:
                    s.remove_key(t)
        self.app.edit(fn)
        self.selected = []

    def move_keys(self, times, dt: float, copy: bool = False) -> None:
        """Move (or copy) the keys at ``times`` by ``dt`` seconds: one undo step; nothing
        changes when one cannot (a time below 0, or a key already at the new time)."""
        times = sorted(times, reverse=dt > 0)
        new = {t: self.snap_time(t + dt) for t in times}
        if all(same(t, new[t]) for t in times):
            return
        what = ("copy" if copy else "move") + (" keys" if len(times) > 1 else f" key at {times[0]:g} s")

        def fn(s):
            before = s.to_dict()
            try:
                with s.block(what):
                    for t in times:
                        (s.copy_key if copy else s.move_key)(t, new[t])
            except Exception:
                if s.to_dict() != before:
                    s.undo()
                raise
        self.app.edit(fn)
        self.selected = [new[t] for t in times]

    def set_ease(self, ease: str, curve=None, times=None) -> None:
        times = list(self.selected if times is None else times)
        if ease == "bezier" and curve is None:
            curve = DEFAULT_CURVE
        curve = None if ease != "bezier" else [float(c) for c in curve]

        def fn(s):
            with s.block("ease " + ease):
                for t in times:
                    s.set_key_ease(t, ease, curve)
        self.app.edit(fn, key="key-ease")

    def copy(self) -> None:
        ks = [k for k in self.keys() if any(same(k["time"], t) for t in self.selected)]
        if not ks:
            self.app.say("select keys to copy first", "error")
            return
        t0 = min(float(k["time"]) for k in ks)
        self.clipboard = [dict(k, time=float(k["time"]) - t0) for k in ks]
        self.app.say(f"copied {len(ks)} key{'s' if len(ks) > 1 else ''}")

    def paste(self) -> None:
        """Paste the copied keys at the playhead (a key already there is replaced)."""
        if not self.clipboard:
            self.app.say("nothing to paste: select keys and press Ctrl+C", "error")
            return
        at, keys = self.time, list(self.clipboard)

        def fn(s):
            with s.block(f"paste keys at {at:g} s"):
                for k in keys:
                    set_key_dict(s, round(at + k["time"], 6), k)
        self.app.edit(fn)
        self.selected = [round(at + k["time"], 6) for k in keys]

    def set_fps(self, fps: float) -> None:
        self.app.edit(lambda s: s.set_fps(float(fps)), key="fps")


def key_pins(key: dict) -> dict:
    """The pins a key (file form) sets: a pins key's, or a pose key's ``overrides`` that
    are not null."""
    if "pins" in key:
        return key["pins"]
    return {n: v for n, v in (key.get("overrides") or {}).items() if v is not None}


def in_row(key: dict, pin: str | None) -> bool:
    """Whether the key has a mark in the timeline row of ``pin`` (None: the poses row)."""
    return "pose" in key if pin is None else pin in key_pins(key)


def set_key_dict(s, t: float, k: dict) -> None:
    """Set a key from its file form (``pose`` with its ``overrides``, or ``pins``; ``ease``,
    ``curve``) at ``t``."""
    kw = {"ease": k.get("ease", "linear"), "curve": k.get("curve")}
    if "pose" in k:
        s.set_key(t, k["pose"], overrides=k.get("overrides") or None, **kw)
    else:
        s.set_key(t, pins=k["pins"], **kw)


def ruler_step(px_per_s: float) -> float:
    """Seconds between labelled ticks so that labels are at least ~60 px apart."""
    for step in (1 / 24, 0.1, 0.25, 0.5, 1, 2, 5, 10, 30, 60, 300):
        if step * px_per_s >= 60:
            return step
    return 10 ** math.ceil(math.log10(60 / max(px_per_s, 1e-9)))
