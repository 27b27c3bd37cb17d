"""The scene thread: the only thread that touches the scene (loading, edits, solves,
saving), so that the window keeps drawing while a solve runs.

The window posts jobs (``worker.submit(fn)``; ``fn(worker)`` runs on the scene thread)
and draws the latest :class:`Snapshot` the thread published: immutable facts about the
scene (validated data, posed layers, images, undo labels, whether it is saved). Jobs
given the same ``key`` coalesce: a pending one is replaced by the newer (pointer moves
during a drag, slider values), so the thread never falls behind the pointer. A job's
:class:`~puppet.errors.SceneError` becomes a status message, never a traceback.
"""
from __future__ import annotations

import collections
import os
import sys
import threading
import time
import traceback
from dataclasses import dataclass, field, replace
from typing import Any, Callable

from puppet.errors import SceneError


@dataclass(frozen=True)
class Snapshot:
    """What the window shows, as published by the scene thread after a job.

    ``layers`` are the shown pose's :class:`~puppet.scene.rig.LayerResult` (rest in Pin
    mode, the active pose in Pose mode, or a drag preview when ``preview``)."""

    version: int
    file: str | None = None
    data: Any = None
    active: str = "rest"
    shown: str = "rest"
    poses: tuple[str, ...] = ()
    layers: tuple = ()
    images: tuple = ()
    image_keys: tuple = ()
    rank: tuple = ()
    canvas: tuple[int, int] = (0, 0)
    background: Any = (0, 0, 0, 0)
    underlay: dict | None = None
    underlay_image: Any = None
    undo_label: str | None = None
    redo_label: str | None = None
    dirty: bool = False
    preview: bool = False
    done: int = 0  # id of the last job that had run when this was published
    time: float | None = None  # the animation time shown (None: a pose)
    animation: dict | None = None  # the scene's "animation" as in the file (keys, fps)
    ghosts: tuple = ()  # onion skin: (side "before" | "after", weight 0..1, layers)

    @property
    def loaded(self) -> bool:
        return self.data is not None


@dataclass
class Message:
    text: str
    level: str = "info"  # info | error
    time: float = field(default_factory=time.monotonic)


class Worker:
    """Runs jobs on one scene thread and publishes snapshots (see module docstring)."""

    def __init__(self):
        self.scene = None
        self.saved_doc: dict | None = None
        self.show_rest = False
        self.show_time: float | None = None  # show the animation at this time (the timeline)
        self.onion: dict | None = None  # onion skin settings (see puppet.app.onion)
        self.drag = None  # a puppet.drag.Drag while a pin is dragged in a pose
        self.blocks: dict[str, Any] = {}  # open undo blocks by key (multi-frame gestures)
        self.latest = Snapshot(0)
        self.messages: collections.deque[Message] = collections.deque(maxlen=50)
        self.debug = bool(os.environ.get("PUPPET_DEBUG"))
        self._jobs: collections.deque = collections.deque()
        self._cv = threading.Condition()
        self._running = 0
        self._version = 0
        self._ids = 0
        self.done = 0
        self._stop = False
        self._thread = threading.Thread(target=self._loop, name="puppet-scene", daemon=True)
        self._thread.start()

    # -- called from the window thread ----------------------------------------------------
    def submit(self, fn: Callable[["Worker"], Any], *, key: str | None = None, publish: bool = True) -> int:
        """Run ``fn(worker)`` on the scene thread after the jobs already posted; with ``key``,
        replace a pending (not started) job of the same key instead of queueing another.
        Returns the job's id: snapshots with ``done >= id`` show its effect."""
        with self._cv:
            self._ids += 1
            job = (fn, key, publish, self._ids)
            if key is not None:
                for i, old in enumerate(self._jobs):
                    if old[1] == key:
                        del self._jobs[i]
                        break
            self._jobs.append(job)
            self._cv.notify_all()
            return self._ids

    def idle(self) -> bool:
        with self._cv:
            return not self._jobs and not self._running

    def wait_idle(self, timeout: float = 60.0) -> bool:
        """Block until every posted job has run (tests, quitting); False on timeout."""
        end = time.monotonic() + timeout
        with self._cv:
            while self._jobs or self._running:
                left = end - time.monotonic()
                if left <= 0:
                    return False
                self._cv.wait(left)
        return True

    def stop(self, timeout: float = 10.0) -> None:
        with self._cv:
            self._stop = True
            self._cv.notify_all()
        self._thread.join(timeout)

    def say(self, text: str, level: str = "info") -> None:
        self.messages.append(Message(text, level))

    # -- the scene thread -------------------------------------------------------------------
    def _loop(self) -> None:
        while True:
            with self._cv:
                while not self._jobs and not self._stop:
                    self._cv.wait()
                if self._stop:
                    return
                fn, key, publish, job_id = self._jobs.popleft()
                self._running += 1
            try:
                self._run(fn, publish, job_id)
            finally:
                with self._cv:
                    self._running -= 1
                    self._cv.notify_all()

    def _top(self):
        h = self.scene.history if self.scene is not None else None
        return (h.undo_stack[-1] if h and h.undo_stack else None, len(h.undo_stack) if h else 0)

    def _run(self, fn, publish: bool, job_id: int) -> None:
        self.done = job_id
        try:
            before = self._top()
            result = fn(self)
            if isinstance(result, str):
                self.say(result)
            elif self.scene is not None and self._top() != before and self._top()[0] is not None \
                    and not self.scene.history.in_block:
                self.say(self._top()[0].label)  # what was done replaces an old error
        except SceneError as e:
            self.say(str(e), "error")
        except Exception as e:  # a bug: keep the window alive, say what happened
            self.say(f"internal error: {type(e).__name__}: {e}", "error")
            if self.debug:
                traceback.print_exc(file=sys.stderr)
        if publish:
            try:
                self.publish()
            except SceneError as e:
                self.say(str(e), "error")
            except Exception as e:
                self.say(f"internal error: {type(e).__name__}: {e}", "error")
                if self.debug:
                    traceback.print_exc(file=sys.stderr)

    def publish(self, layers=None, preview: bool = False) -> Snapshot:
        """Build and publish the snapshot of the scene as it is now (``layers``: a drag
        preview to show instead of the solved pose)."""
        self._version += 1
        s = self.scene
        if s is None:
            self.latest = Snapshot(self._version, done=self.done)
            return self.latest
        old = self.latest
        if preview and old.loaded and old.file == s.file:
            snap = replace(old, version=self._version, layers=tuple(layers), preview=True, done=self.done)
        else:
            snap = self._full(layers)
        self.latest = snap
        return snap

    def _full(self, layers) -> Snapshot:
        s = self.scene
        shown = "rest" if self.show_rest else s.active_pose
        built = s.built
        doc = s.to_dict()
        from puppet.app import onion

        t, ghosts = onion.frame_of(self, doc.get("animation"))  # the timeline's time, onion skin
        if layers is None:
            layers = s.layers("rest" if self.show_rest else None) if t is None else onion.layers_at(self, t)
        if t is not None:
            shown = f"{t:.2f} s"

        h = s.history
        underlay = s.underlay
        try:
            under_img = s.underlay_image() if underlay else None
        except SceneError as e:
            self.say(str(e), "error")
            under_img = None
        return Snapshot(
            version=self._version, file=s.file, data=s.data, active=s.active_pose, shown=shown,
            poses=tuple(s.pose_names()), layers=tuple(layers), images=tuple(built.images),
            image_keys=tuple(built.image_keys), rank=tuple(built.rank), canvas=tuple(s.canvas),
            background=s.background(), underlay=underlay, underlay_image=under_img,
            undo_label=h.undo_stack[-1].label if h.can_undo() else None,
            redo_label=h.redo_stack[-1].label if h.can_redo() else None,
            dirty=self.saved_doc is None or doc != self.saved_doc, done=self.done,
            time=t, animation=doc.get("animation"), ghosts=ghosts)

    # -- helpers for jobs (scene thread only) ----------------------------------------------
    def set_scene(self, scene, saved_doc: dict | None) -> None:
        """Make ``scene`` the open scene; ``saved_doc`` is what its file holds (None: unsaved)."""
        if self.drag is not None:
            self.drag.cancel()
            self.drag = None
        for key in list(self.blocks):
            self.end_block(key)
        self.scene, self.saved_doc = scene, saved_doc

    def begin_block(self, key: str, label: str) -> None:
        """Open an undo block that stays open across jobs until :meth:`end_block`."""
        if key in self.blocks or self.scene is None:
            return
        ctx = self.scene.block(label)
        ctx.__enter__()
        self.blocks[key] = ctx

    def end_block(self, key: str) -> None:
        ctx = self.blocks.pop(key, None)
        if ctx is not None:
            ctx.__exit__(None, None, None)

