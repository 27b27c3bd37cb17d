"""The scene session: the one thread that owns the document, the drag, the frame cache
and what the canvas shows, and the typed intents the window posts to it.

The window calls the intents (:meth:`SceneSession.open`, :meth:`~SceneSession.show`,
:meth:`~SceneSession.begin_drag` / :meth:`~SceneSession.move_drag` /
:meth:`~SceneSession.end_drag`, :meth:`~SceneSession.edit`, ...); each posts a job that
runs on the scene thread, after the jobs posted before it, and then publishes an
immutable :class:`~puppet.app.model.snapshot.Snapshot` that the window draws. Jobs given the
same ``key`` coalesce (a pending one is replaced by the newer: pointer moves during a
drag, slider values), so the scene thread never falls behind the pointer. An error a
user can cause (:class:`~puppet.errors.SceneError`) becomes a status message, never a
traceback.
"""
from __future__ import annotations

import collections
import os
import sys
import threading
import time
import traceback
from dataclasses import replace
from typing import Any, Callable

from puppet.app.model import autosave, opening
from puppet.app.model.snapshot import (
    FrameCache,
    Message,
    Shown,
    Snapshot,
    build_snapshot,
)
from puppet.errors import SceneError
from puppet.scene.drag.process import DragProcess
from puppet.scene.drag.session import warm

_KEEP = object()
#: the default of :attr:`SceneSession.solver` (``PUPPET_APP_SOLVER`` overrides it)
SOLVER = "thread"


class SceneSession:
    """The scene thread and its intents (see the module docstring).

    Attributes (scene thread only, except ``latest`` and ``messages``)
    ----------
    scene : puppet.api.Scene or None
    saved_doc : dict or None
        What the scene's file holds (None: never saved).
    shown : Shown
        What the canvas shows: the rest pose, the active pose, or the animation at a time.
    latest : Snapshot
        The last published snapshot (read from any thread).
    """

    def __init__(self, solver: str | None = None):
        #: where drag previews are solved: "thread" (this scene thread; the solver releases
        #: the GIL in its solves) or "process" (a child python, puppet.scene.drag.process)
        self.solver = solver or os.environ.get("PUPPET_APP_SOLVER", SOLVER)
        if self.solver not in ("thread", "process"):
            raise ValueError(f"solver must be 'thread' or 'process', got {self.solver!r}")
        self._proc = None  # the DragProcess, started with the first scene
        self.scene = None
        self.saved_doc: dict | None = None
        self.shown = Shown()
        self.frames = FrameCache()
        self._drag = None  # the open puppet.scene.drag.session.DragSession
        self._warmed = None  # the built scene whose drag previews were built ahead (_warm)
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

    # -- intents (window thread) -----------------------------------------------------------
    def open(self, path: str, *, picture: bool, recover_from: str | None = None, rest: bool = False) -> int:
        """Open the scene at ``path`` (or a new scene over the picture ``path``; or the
        autosave ``recover_from`` in its place); show rest when ``rest``."""
        def job():
            scene, saved, msg = opening.load(path, picture=picture, recover_from=recover_from)
            self._set_scene(scene, saved)
            self._solver()  # the child starts while the user looks at the scene
            self.shown = replace(self.shown, rest=rest or picture)
            return msg
        return self._post(job)

    def close_scene(self) -> int:
        return self._post(lambda: self._set_scene(None, None))

    def save(self, path: str | None = None) -> int:
        """Save to the scene's file (or ``path``: Save As), atomically."""
        def job():
            s = self._need()
            target = path or s.file
            s.save(target)
            if target != s.file:
                autosave.remove(s.file)
                s.file = target
            self.saved_doc = s.to_dict()
            autosave.remove(target)
            return f"saved {target}"
        return self._post(job)

    def autosave(self) -> int:
        def job():
            if self.scene is not None:
                autosave.write(self.scene)
        return self._post(job, publish=False)

    def write_copy(self, folder: str, then: Callable[[str | None], None]) -> int:
        """Write the scene as it is now to ``folder/scene.json`` and call ``then(path)`` on
        the scene thread (``then(None)`` when no scene is open)."""
        def job():
            import json

            if self.scene is None:
                return then(None)
            path = os.path.join(folder, "scene.json")
            with open(path, "w") as f:
                json.dump(self.scene.to_json(folder), f)
            then(path)
        return self._post(job, publish=False)

    def after(self, fn: Callable[[bool], None]) -> int:
        """Call ``fn(saved)`` on the scene thread once the jobs posted before have run;
        ``saved``: the scene is as its file holds it."""
        return self._post(lambda: fn(self.scene is None or self.saved_doc == self.scene.to_dict()),
                          publish=False)

    def show(self, *, rest=_KEEP, time=_KEEP, onion=_KEEP) -> int:
        """What the canvas shows: ``rest`` (Pin mode), the animation at ``time`` (None: the
        active pose), the onion skin settings (None: off)."""
        change = {k: v for k, v in (("rest", rest), ("time", time), ("onion", onion)) if v is not _KEEP}
        if "onion" in change and change["onion"] is not None:
            change["onion"] = tuple(sorted(change["onion"].items()))

        def job():
            self.shown = replace(self.shown, **change)
        return self._post(job, key="show-" + "-".join(sorted(change)))

    def edit(self, fn: Callable, *, key: str | None = None) -> int:
        """Run ``fn(scene)`` on the scene thread (an edit; what it returns, a string, is the
        status message). Returns the job id: snapshots with ``done >= id`` show it."""
        return self._post(lambda: fn(self._need()), key=key)

    def build(self) -> int:
        """Build the meshes (the task script's Deform step)."""
        def job():
            s = self._need()
            s.built
            return f"meshes built: {sum(len(r.triangles) for r in s.layers('rest'))} triangles; drag pins to pose"
        return self._post(job)

    def begin_block(self, key: str, label: str) -> int:
        """Open an undo block that stays open across jobs until :meth:`end_block`."""
        def job():
            if key not in self.blocks and self.scene is not None:
                ctx = self.scene.block(label)
                ctx.__enter__()
                self.blocks[key] = ctx
        return self._post(job, publish=False)

    def end_block(self, key: str) -> int:
        return self._post(lambda: self._end_block(key))

    def cancel_block(self, key: str) -> int:
        """Close block ``key`` and take back what it did (no undo step, no redo step)."""
        def job():
            s, ctx = self.scene, self.blocks.pop(key, None)
            if ctx is None or s is None:
                return
            top = s.history.undo_stack[-1] if s.history.undo_stack else None
            ctx.__exit__(None, None, None)
            if s.history.undo_stack and s.history.undo_stack[-1] is not top:
                s.undo()
                s.history.redo_stack.pop()
        return self._post(job)

    def prefetch(self, times) -> int:
        """Solve the animation's frames at ``times`` ahead of playing, one a job (behind
        whatever the window posts meanwhile); stops when the scene changes."""
        times = [round(float(t), 6) for t in times][:self.frames.size]

        def job():
            s = self.scene
            if s is None or s.data.animation is None:
                return None
            data = s.data
            todo = self.frames.missing(data, times)
            if todo:
                self.frames.layers_at(s, todo[0])
            if len(todo) > 1 and self.scene is s and s.data is data:
                self._post(job, key="prefetch", publish=False)
        return self._post(job, key="prefetch", publish=False)

    def cached_frames(self) -> int:
        """How many frames of the scene as it is now are solved (a glance, any thread)."""
        s = self.scene
        return self.frames.count(s.data) if s is not None else 0

    # -- drags ---------------------------------------------------------------------------
    def begin_drag(self, names, *, time: float | None = None, record: bool = False) -> int:
        """Start dragging pins ``names`` in the active pose (``time``: in the animation at
        that time, keyed there on release; ``record``: a recording from ``time``)."""
        names = list(names)

        def job():  # the core's warm-started drag session: the one way a pin is dragged
            self._cancel_drag()
            self._drag = self._need().drag(names, time=time, record=record, solver=self._solver())
        return self._post(job, publish=False)

    def move_drag(self, positions: dict, *, time: float | None = None) -> int:
        """The dragged pins at canvas ``positions``: publish a preview (coalesced: only the
        newest pending move runs). ``time``: a recording moves the time too."""
        positions = dict(positions)

        def job():
            if self._drag is not None:
                self._publish(self._drag.move_layers(positions, time=time), preview=True)
        return self._post(job, key="drag-move", publish=False)

    def end_drag(self, positions: dict | None = None, *, keys: dict | None = None,
                 message: str | None = None) -> int:
        """Release: the pins at ``positions`` (a recording: its ``keys``, {time: {pin: xy}})
        become one undo step, solved exactly; with neither, the drag ends changing nothing.
        ``message``: the status line afterwards."""
        positions = None if positions is None else dict(positions)

        def job():
            d, self._drag = self._drag, None
            if d is None:
                return None
            if positions is None and not keys:
                d.cancel()
                return None
            try:
                if positions is not None:
                    d.move_layers(positions)
                d.commit(keys=keys) if keys else d.commit()
            except BaseException:
                d.cancel()
                raise
            return message
        return self._post(job)

    # -- window-thread helpers -------------------------------------------------------------
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
        """Stop the scene thread (after the job it is running) and the solver process."""
        with self._cv:
            self._stop = True
            self._cv.notify_all()
        self._thread.join(timeout)
        if self._proc is not None:
            self._proc.close()
            self._proc = None

    def say(self, text: str, level: str = "info") -> None:
        self.messages.append(Message(text, level))

    # -- the scene thread ------------------------------------------------------------------
    def _post(self, fn: Callable[[], Any], *, key: str | None = None, publish: bool = True) -> int:
        with self._cv:
            self._ids += 1
            if key is not None:
                for i, old in enumerate(self._jobs):
                    if old[1] == key:
                        del self._jobs[i]
                        break
            self._jobs.append((fn, key, publish, self._ids))
            self._cv.notify_all()
            return self._ids

    def _solver(self):
        """The drag process when previews are solved in one (started, or restarted after it
        died, on the scene thread), else None."""
        if self.solver != "process":
            return None
        if self._proc is None or not self._proc.alive:
            if self._proc is not None:
                self._proc.close()
            self._proc = DragProcess()
        return self._proc

    def _need(self):
        if self.scene is None:
            raise SceneError("no scene is open")
        return self.scene

    def _loop(self) -> None:
        while True:
            with self._cv:
                idle = not self._jobs and not self._stop
                self._running += idle
            if idle:  # nothing asked: build ahead what a drag's first frame needs (counted as a job)
                try:
                    self._guard(self._warm)
                finally:
                    with self._cv:
                        self._running -= 1
                        self._cv.notify_all()
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

    def _warm(self) -> None:
        """Once per built version of the scene: :func:`puppet.scene.drag.session.warm`
        (a failed build says nothing here: the job that shows the scene says it)."""
        scene = self.scene
        if scene is None or self._drag is not None:
            return
        try:
            built = scene.built
        except SceneError:
            return
        if built is not self._warmed:
            self._warmed = built
            warm(scene)

    def _top(self):
        h = self.scene.history if self.scene is not None else None
        return (h.undo_stack[-1] if h and h.undo_stack else None, len(h.undo_stack) if h else 0)

    def _run(self, fn, publish: bool, job_id: int) -> None:
        self.done = job_id
        before = self._top()
        result = self._guard(fn)
        if isinstance(result, str):
            self.say(result)
        elif self.scene is not None and self._top() != before and self._top()[0] is not None \
                and not self.scene.history.in_block:
            self.say(self._top()[0].label)  # what was done replaces an old error
        if publish:
            self._guard(self._publish)

    def _guard(self, fn):
        try:
            return fn()
        except SceneError as e:
            self.say(str(e), "error")
        except Exception as e:  # a bug: keep the window alive, say what happened
            self.say(f"internal error: {type(e).__name__}: {e}", "error")
            if self.debug:
                traceback.print_exc(file=sys.stderr)
        return None

    def _publish(self, layers=None, preview: bool = False) -> Snapshot:
        """Publish the snapshot of the scene as it is now (``layers``: a drag preview shown
        instead of the solved pose)."""
        self._version += 1
        old = self.latest
        if self.scene is None:
            snap = Snapshot(self._version, done=self.done)
        elif preview and old.loaded and old.file == self.scene.file:
            snap = replace(old, version=self._version, layers=tuple(layers), preview=True, done=self.done)
        else:
            snap = build_snapshot(self, self._version, layers)
        self.latest = snap
        return snap

    def _set_scene(self, scene, saved_doc: dict | None) -> None:
        self._cancel_drag()
        for key in list(self.blocks):
            self._end_block(key)
        self.scene, self.saved_doc = scene, saved_doc
        self.frames.clear()

    def _cancel_drag(self) -> None:
        if self._drag is not None:
            self._drag.cancel()
            self._drag = None

    def _end_block(self, key: str) -> None:
        ctx = self.blocks.pop(key, None)
        if ctx is not None:
            ctx.__exit__(None, None, None)
