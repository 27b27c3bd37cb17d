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
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterator

import numpy as np

from puppet.errors import SceneError
from puppet.scene.document.core import Document
from puppet.scene.drag.child import child_setup, messages, start_child, stop_child

#: Fields sent back per layer and frame (the others come from the template frame).
STATIC = ("rest", "triangles")
#: Frames asked for ahead of the one being read.
WINDOW = 3


def _pack(layers) -> list[dict]:
    return [{f.name: getattr(r, f.name) for f in dataclasses.fields(r) if f.name not in STATIC} for r in layers]


def child_main(fd: int) -> None:
    """The child process: ``python -c "...child_main(FD)"`` with one end of a socket pair."""
    conn = child_setup(fd)
    try:
        doc, file, t0, rate = conn.recv()
    except (EOFError, OSError):
        return
    _child(conn, doc, file, t0, rate)


def _child(conn, doc: dict, file: str, t0: float, rate: float) -> None:
    """The child's loop: frame index in, ``("ok", i, packed layers, seconds)`` out."""
    try:
        scene = Document(doc, file)
        scene.built  # noqa: B018
        conn.send(("ready",))
        for i in messages(conn):
            t = time.perf_counter()
            layers = scene.layers(time=t0 + i / rate)
            conn.send(("ok", i, _pack(layers), time.perf_counter() - t))
    except BaseException as e:  # noqa: BLE001 - reported to the parent, which raises it
        try:
            conn.send(("error", type(e).__name__, str(e), isinstance(e, SceneError)))
        except (OSError, ValueError):
            pass


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.dtype == b.dtype \
            and np.array_equal(a, b)
    return a == b


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

    def start(self, first: int, wait: Callable[[], bool] = lambda: False) -> bool:
        """Start the child and check it solves frame ``first`` exactly as this process
        does; False (child stopped) when it cannot be used."""
        try:
            self.proc, self.conn = start_child("puppet.anim.solver", "child_main")
        except OSError:
            return False
        try:
            self.conn.send((self.scene.to_dict(), self.scene.file, self.t0, self.rate))
        except OSError:
            self.close()
            return False
        self.template = self.scene.layers(time=self.t0 + first / self.rate)  # (meanwhile the child starts)
        try:
            self.conn.send(first)
            there = self._receive(wait)
        except (SceneError, RuntimeError):
            self.close()
            return False
        if there is None or len(there) != len(self.template) or not all(
                _same(getattr(r, k), v) for r, d in zip(self.template, there) for k, v in d.items()):
            self.close()
            return False
        return True

    def _receive(self, stop: Callable[[], bool]):
        """The next result's packed layers (None when ``stop()`` turned true while waiting)."""
        while not self.conn.poll(0.05):
            if stop():
                return None
            if self.proc.poll() is not None and not self.conn.poll():
                raise RuntimeError(f"the solver process ended (exit status {self.proc.returncode})")
        msg = self.conn.recv()
        if msg[0] == "ready":
            return self._receive(stop)
        if msg[0] == "error":
            _, name, text, user = msg
            raise SceneError(text) if user else RuntimeError(f"solver process: {name}: {text}")
        self.seconds = msg[3]
        return msg[2]

    def results(self, indices: list[int], stop: Callable[[], bool]) -> Iterator[tuple[int, list, float]]:
        """``(i, layers, solve seconds)`` for each index in order, keeping :data:`WINDOW`
        frames asked for ahead; ends early when ``stop()`` turns true."""
        sent = 0
        for _ in range(min(WINDOW, len(indices))):
            self.conn.send(indices[sent])
            sent += 1
        for i in indices:
            packed = self._receive(stop)
            if packed is None:
                return
            if sent < len(indices):
                self.conn.send(indices[sent])
                sent += 1
            yield i, [dataclasses.replace(r, **d) for r, d in zip(self.template, packed)], self.seconds

    def close(self) -> None:
        """Stop the child (asked first, then terminated) and wait for it."""
        if self.proc is None:
            return
        stop_child(self.proc, self.conn)
        self.proc = None
