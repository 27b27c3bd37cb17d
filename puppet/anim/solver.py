"""Solve frames in a child process, so that solving does not wait for the GIL.

moderngl holds the GIL through every GL call (a read-back waits there for the
rasteriser), and most of a solve is Python and GIL-holding C (the sparse solver, small
numpy calls): a solver *thread* and the compositing thread take turns rather than run
side by side (measured with the machine busy: a solver thread solved ~30 % fewer frames per second
next to the compositor than a solver process; with it quiet, a whole export was as fast
either way, so the export uses a thread unless asked, ``solver="process"``). A :class:`ProcessSolver` loads the same
scene in a child (a fresh ``python``: no GL state is inherited, and unlike
``multiprocessing``'s spawn, the caller's main script is not imported again there, so a
script without an ``if __name__ == "__main__"`` guard is safe), solves the frames it is asked
for, in order, and sends back what changes per frame (every :class:`LayerResult` field
but ``rest`` and ``triangles``, which are taken from a frame solved here). The first
frame is solved on both sides and compared: any difference (an edit the scene file does
not hold) makes :meth:`ProcessSolver.start` return False, and the export solves on a
thread instead. Results are therefore identical to an in-process solve.

A :class:`SolverPool` runs several such children (``puppet animate --workers N``): frames
are independent given the keys, so they are solved side by side and handed on in order,
with a bounded number in flight; a child that dies stops the export with one line
(:class:`SolverLost`).

A pool's children can also draw their frames (:meth:`SolverPool.draw`): each composites
the frame it solved with its own GL context (created on its first frame), exactly as
the export draws it here, and encodes it with the sink's :class:`Drawing.ship` function
(a frame's PNG file, its GIF palette indices, its video planes), so that this process
only writes what comes back, in order. Each child's first drawn frame is compared with
the frame drawn here, and its encoding with the encoding made here; any difference (or a
child that cannot draw) turns drawing off in every child, and the export draws here as
before.
"""
from __future__ import annotations

import dataclasses
import subprocess
import time
from collections.abc import Callable, Iterator
from multiprocessing.connection import wait

import numpy as np

from puppet.api import Scene
from puppet.errors import SceneError
from puppet.scene.rig import disk
from puppet.scene.drag.child import child_setup, messages, start_child, stop_child

#: Fields sent back per layer and frame (the others come from the template frame).
STATIC = ("rest", "triangles")
#: Frames asked for ahead of the one being read.
WINDOW = 3
_READY = object()


def _pack(layers) -> list[dict]:
    return [{f.name: getattr(r, f.name) for f in dataclasses.fields(r) if f.name not in STATIC} for r in layers]


@dataclasses.dataclass(frozen=True)
class Drawing:
    """How a solver process draws and encodes a frame (sent to it once, pickled): the
    export's ``draw_layers`` options and ``ship``, a picklable ``rgba -> item`` whose
    item the sink writes (:meth:`puppet.anim.sinks.Sink.shipper`)."""

    size: tuple | None
    wireframe: bool
    background: object
    ship: Callable

    def composite(self, scene, layers) -> np.ndarray:
        return scene.draw_layers(layers, size=self.size, wireframe=self.wireframe, background=self.background)


def child_main(fd: int) -> None:
    """The child process: ``python -c "...child_main(FD)"`` with one end of a socket pair."""
    conn = child_setup(fd)
    try:
        doc, file, t0, rate = conn.recv()
    except (EOFError, OSError):
        return
    _child(conn, doc, file, t0, rate)


def _child(conn, doc: dict, file: str, t0: float, rate: float) -> None:
    """The child's loop: frame index in, ``("ok", i, packed layers, {stage: seconds})``
    out; while drawing, the frame's encoded item instead of its layers. ``("draw",
    Drawing, i)`` turns drawing on (answered by frame ``i``'s ``(rgba, item)``, or None
    when it cannot be drawn here: drawing stays off); ``("draw", None, None)`` turns it off."""
    try:
        scene = Scene(doc, file)  # (its compositor, and GL, only once it draws)
        scene.rig.memo.disk = disk.beside(file)  # the parts the parent built, read, not made again
        scene.built  # noqa: B018
        conn.send(("ready",))
        drawing = None
        for msg in messages(conn):
            if isinstance(msg, tuple):
                drawing = _first_drawn(conn, scene, msg[1], msg[2], t0 + msg[2] / rate) if msg[1] else None
                continue
            t = time.perf_counter()
            layers = scene.layers(time=t0 + msg / rate)
            times = {"solve": time.perf_counter() - t}
            conn.send(("ok", msg, _pack(layers) if drawing is None else _drawn(scene, layers, drawing, times), times))
    except BaseException as e:  # noqa: BLE001 - reported to the parent, which raises it
        try:
            conn.send(("error", type(e).__name__, str(e), isinstance(e, SceneError)))
        except (OSError, ValueError):
            pass


def _drawn(scene, layers, drawing: Drawing, times: dict):
    """The frame of ``layers`` drawn and encoded; the seconds each took added to ``times``."""
    t = time.perf_counter()
    rgba = drawing.composite(scene, layers)
    t1 = time.perf_counter()
    item = drawing.ship(rgba)
    times.update(composite=t1 - t, encode=time.perf_counter() - t1)
    return item


def _first_drawn(conn, scene, drawing: Drawing, i: int, at: float) -> Drawing | None:
    """Answer ``("draw", drawing, i)``: send frame ``i`` drawn and encoded, ``(rgba,
    item)``, and return ``drawing``; or send None and return None when it cannot be
    drawn here (no GL, a size this GL cannot draw)."""
    t = time.perf_counter()
    try:
        layers = scene.layers(time=at)
        rgba = drawing.composite(scene, layers)
        got = (rgba, drawing.ship(rgba))
    except Exception:  # noqa: BLE001 - the export draws in the parent instead
        got = drawing = None
    conn.send(("ok", i, got, {"solve": time.perf_counter() - t}))
    return drawing


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.dtype == b.dtype \
            and np.array_equal(a, b)
    return a == b


class SolverLost(SceneError):
    """A solver process ended without being asked (killed, out of memory): the export stops
    and writes nothing."""


class ProcessSolver:
    """Frames ``scene.layers(time=t0 + i / rate)`` solved in a child process.

    Parameters
    ----------
    scene : the scene (its :meth:`to_dict` and ``file`` are sent to the child).
    t0, rate : frame ``i`` is at ``t0 + i / rate`` seconds.
    """

    def __init__(self, scene, t0: float, rate: float):
        self.scene, self.t0, self.rate = scene, t0, rate
        self.proc = self.conn = None
        self.template = None
        self.sent: list[int] = []  # frames asked for and not yet received, in order
        self.drawing = False  # the child sends frames drawn and encoded, not layers
        self.times: dict[str, float] = {}  # the last frame's seconds per stage, there

    def start(self, first: int, wait: Callable[[], bool] = lambda: False) -> bool:
        """Start the child and check it solves frame ``first`` exactly as this process
        does; False (child stopped) when it cannot be used."""
        if not self.launch():
            return False
        try:
            template = self.scene.layers(time=self.t0 + first / self.rate)  # (meanwhile the child starts)
        except BaseException:
            self.close()
            raise
        return self.check(first, template, wait)

    def launch(self) -> bool:
        """Start the child and send it the scene; False when it cannot be started."""
        try:
            self.proc, self.conn = start_child("puppet.anim.solver", "child_main")
        except OSError:
            return False
        try:
            self.conn.send((self.scene.to_dict(), self.scene.file, self.t0, self.rate))
        except OSError:
            self.close()
            return False
        return True

    def check(self, first: int, template: list, wait: Callable[[], bool] = lambda: False) -> bool:
        """Ask the started child for frame ``first`` and compare it with ``template`` (that
        frame solved here, whose ``rest`` and ``triangles`` the child's frames then
        share); False (child stopped) on any difference."""
        self.template = template
        try:
            self.ask(first)
            there = self.receive(wait)
        except (SceneError, RuntimeError, OSError):
            self.close()
            return False
        if there is None or len(there) != len(self.template) or not all(
                _same(getattr(r, k), v) for r, d in zip(self.template, there) for k, v in d.items()):
            self.close()
            return False
        return True

    def ask(self, i: int) -> None:
        """Ask the child for frame ``i`` (answers come in the order asked)."""
        self.sent.append(i)
        try:
            self.conn.send(i)
        except OSError:  # the child has gone: its pipe is closed
            raise self._gone() from None

    def lost(self) -> bool:
        """The child has ended and nothing more is waiting to be read from it."""
        return self.proc.poll() is not None and not self.conn.poll()

    def receive(self, stop: Callable[[], bool]):
        """The next result's packed layers (None when ``stop()`` turned true while waiting)."""
        while True:
            while not self.conn.poll(0.05):
                if stop():
                    return None
                if self.lost():
                    raise self.ended()
            packed = self.take()
            if packed is not _READY:
                return packed

    def ended(self) -> SolverLost:
        """The error of a child that ended unasked (before the frames it was asked for)."""
        code = self.proc.returncode
        how = f"was killed by signal {-code}" if code is not None and code < 0 else f"ended (exit status {code})"
        at = f" before frame {self.sent[0]}" if self.sent else ""
        return SolverLost(f"a solver process {how}{at}; the export stopped and wrote nothing "
                          "(out of memory? try fewer --workers)")

    def _gone(self) -> SolverLost:
        """:meth:`ended`, once the child whose pipe closed has been waited for (2 s at most)."""
        try:
            self.proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            pass
        return self.ended()

    def take(self):
        """Read one message the child has sent: the packed layers of the oldest frame
        asked for, or ``_READY`` (the child has built the scene); the child's error is
        raised here."""
        try:
            msg = self.conn.recv()
        except (EOFError, OSError):
            raise self._gone() from None
        if msg[0] == "ready":
            return _READY
        if msg[0] == "error":
            _, name, text, user = msg
            raise SceneError(text) if user else RuntimeError(f"solver process: {name}: {text}")
        self.sent.pop(0)
        self.times = msg[3]
        return msg[2]

    def unpack(self, packed: list) -> list:
        """A frame's layers from what the child sent and the template's static fields
        (while drawing: the encoded frame it sent)."""
        if self.drawing:
            return packed
        return [dataclasses.replace(r, **d) for r, d in zip(self.template, packed)]

    def draw(self, drawing: Drawing | None, first: int | None = None) -> None:
        """Ask the child to draw its frames with ``drawing`` (its first frame ``first``,
        answered ``(rgba, item)`` or None; read it with :meth:`take`), or, with None, to
        send layers again."""
        self.drawing = False
        if drawing is not None:
            self.sent.append(first)
        try:
            self.conn.send(("draw", drawing, first))
        except OSError:
            raise self._gone() from None

    def results(self, indices: list[int], stop: Callable[[], bool]) -> Iterator[tuple[int, list, dict]]:
        """``(i, layers, {stage: seconds})`` for each index in order (while drawing, the
        encoded frame instead of its layers), keeping :data:`WINDOW` frames asked for
        ahead; ends early when ``stop()`` turns true."""
        sent = 0
        for _ in range(min(WINDOW, len(indices))):
            self.ask(indices[sent])
            sent += 1
        for i in indices:
            packed = self.receive(stop)
            if packed is None:
                return
            if sent < len(indices):
                self.ask(indices[sent])
                sent += 1
            yield i, self.unpack(packed), self.times

    def close(self) -> None:
        """Stop the child (asked first, then terminated) and wait for it."""
        if self.proc is None:
            return
        stop_child(self.proc, self.conn)
        self.proc = None
        self.sent = []


class SolverPool:
    """Frames solved in ``n`` child processes (:class:`ProcessSolver` each), handed back in
    order: frames are independent given the keys, so which process solves a frame does not
    change it (each child is checked on the first frame, as :meth:`ProcessSolver.start`
    does).

    Each frame goes to the child with the fewest frames asked for, up to :data:`WINDOW`
    each; at most ``n`` x :data:`WINDOW` frames are asked for and not yet handed on
    (solved frames waiting for an earlier one count), so memory is bounded whatever the
    frame count and however uneven the children's speed. A child that ends unasked
    raises :class:`SolverLost`; :meth:`close` stops every child.
    """

    def __init__(self, scene, t0: float, rate: float, n: int):
        self.solvers = [ProcessSolver(scene, t0, rate) for _ in range(n)]
        self.scene, self.t0, self.rate = scene, t0, rate
        self.first, self.template = None, None  # the frame each child was checked on, solved here
        self.held = 0  # most frames asked for and not yet handed on, seen (for tests)

    def start(self, first: int, wait: Callable[[], bool] = lambda: False) -> bool:
        """Start every child and check each solves frame ``first`` as this process does;
        False (every child stopped) when one cannot be used."""
        try:
            if not all(s.launch() for s in self.solvers):
                self.close()
                return False
            template = self.scene.layers(time=self.t0 + first / self.rate)  # (meanwhile the children start)
            self.first, self.template = first, template
            if not all(s.check(first, template, wait) for s in self.solvers):
                self.close()
                return False
        except BaseException:
            self.close()
            raise
        return True

    def draw(self, drawing: Drawing, composite: Callable[[list], np.ndarray],
             wait: Callable[[], bool] = lambda: False) -> bool:
        """Have every child draw and encode its frames with ``drawing`` (:meth:`results`
        then gives encoded frames) when each draws the frame it was checked on as
        ``composite(template)`` draws it here (meanwhile) and encodes it as
        ``drawing.ship`` does here; False (every child sending layers, as before) otherwise."""
        for s in self.solvers:  # all at once: they draw side by side, and while this process does
            s.draw(drawing, self.first)
        rgba = composite(self.template)
        want = drawing.ship(rgba)
        got = [s.receive(wait) for s in self.solvers]
        if all(g is not None and _same(g[0], rgba) and _same(g[1], want) for g in got):
            for s in self.solvers:
                s.drawing = True
            return True
        for s in self.solvers:
            s.draw(None)
        return False

    def results(self, indices: list[int], stop: Callable[[], bool]) -> Iterator[tuple[int, list, dict]]:
        """``(i, layers, {stage: seconds})`` for each index in order (while drawing, the
        encoded frame instead of its layers); ends early when ``stop()`` turns true."""
        solvers, limit = self.solvers, WINDOW * len(self.solvers)
        done: dict[int, tuple] = {}  # position in indices -> (solver, packed, {stage: seconds})
        owner: list[ProcessSolver] = []  # position -> the solver asked
        for pos in range(len(indices)):
            while len(owner) < len(indices) and len(owner) - pos < limit:  # ask ahead
                s = min(solvers, key=lambda s: len(s.sent))
                if len(s.sent) >= WINDOW:
                    break
                s.ask(indices[len(owner)])
                owner.append(s)
            self.held = max(self.held, len(owner) - pos)
            while pos not in done:
                if not self._collect(owner, done, pos, stop):
                    return
            s, packed, times = done.pop(pos)
            yield indices[pos], s.unpack(packed), times

    def _collect(self, owner: list, done: dict, pos: int, stop: Callable[[], bool]) -> bool:
        """Read what the children have sent into ``done`` (waiting at most 50 ms); False
        when ``stop()`` turned true."""
        busy = [s for s in self.solvers if s.sent]
        ready = wait([s.conn for s in busy], timeout=0.05)
        if not ready:
            if stop():
                return False
            for s in busy:
                if s.lost():
                    raise s.ended()
            return True
        for s in busy:
            if s.conn in ready:
                at = self._position(owner, s, pos, done)
                packed = s.take()
                if packed is not _READY:
                    done[at] = (s, packed, s.times)
        return True

    @staticmethod
    def _position(owner: list, s: ProcessSolver, pos: int, done: dict) -> int:
        """The position of ``s``'s oldest frame asked for (the next it answers)."""
        return next(p for p in range(pos, len(owner)) if owner[p] is s and p not in done)

    def close(self) -> None:
        """Stop every child (asked first, then terminated) and wait for them."""
        for s in self.solvers:
            s.close()
