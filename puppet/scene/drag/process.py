"""Drag previews solved in a child process, so that no solve holds the window's GIL.

A :class:`DragProcess` is a long-lived child (a fresh ``python``, one BLAS thread) that
keeps a copy of the scene and its built parts (its rig's cache survives from drag to
drag: only what an edit changed is rebuilt there). A drag session given one
(``doc.drag(names, solver=proc)``) sends it the document and the drag when it opens, the
targets on each move, and gets back the posed layers of the groups the move changed; the
thread that waits for them only waits on a socket, without the GIL. Until the child has
built the scene version (its first drag after an edit of the meshes), and whenever it is
not there, the session solves in its own thread instead. The child runs the very same
:class:`~puppet.scene.drag.session.DragSession` code on the same inputs, so its previews are the
in-thread ones bit for bit (a test checks it); the release is always solved by the
caller's own document, exactly.

``benchmarks/bench_solver.py`` measures this against a solver thread: with the machine
very busy (load 10-11), a 60 Hz window beside previews without pause was late by a median
1-3 ms with the process against 9-19 ms with a thread (p99 19-27 ms against 139-369 ms);
at load 5-7 the two varied from run to run (p99 13-39 ms against 12-76 ms).
"""
from __future__ import annotations

import dataclasses

from puppet.scene.drag.child import start_child, stop_child


class DragProcess:
    """A child process that solves drag previews (see the module docstring).

    Use from one thread (the scene thread); :meth:`close` when done.
    """

    def __init__(self):
        self.proc, self.conn = start_child("puppet.scene.document.drag_child", "child_main", {
            "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "PUPPET_BLAS_SET_AT_START": "1"})
        self.serial = 0  # the drag the child is asked to serve
        self.ready = 0  # the last drag it said it is ready for

    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def open(self, doc, names, time, record: bool, iterations: int) -> int:
        """Ask the child to open the same drag on its copy of ``doc``; returns its number."""
        self.serial += 1
        try:
            self.conn.send(("open", self.serial, doc.to_dict(), doc.file, doc.active_pose, list(names), time,
                            record, iterations))
        except (OSError, ValueError):  # the child is gone: it never becomes ready, the drag solves itself
            pass
        return self.serial

    def wait_ready(self, serial: int, timeout: float | None = None) -> bool:
        """Wait (``timeout`` seconds; None: no limit; 0: only look) until the child serves
        drag ``serial``; False if it does not (yet)."""
        while self.ready < serial:
            if not self.alive or not self.conn.poll(timeout):
                return False
            msg = self.conn.recv()
            if msg[0] == "ready":
                self.ready = msg[1]
            elif msg[0] == "error" and msg[1] == serial:
                return False
        return self.ready == serial

    def move(self, serial: int, targets: dict, time) -> dict | None:
        """The child's packed preview of drag ``serial`` (see
        :func:`puppet.scene.document.drag_child.pack`), or None."""
        try:
            self.conn.send(("move", serial, {n: [float(v) for v in xy] for n, xy in targets.items()}, time))
            while True:
                msg = self.conn.recv()
                if msg[0] == "ready":
                    self.ready = msg[1]
                elif msg[1] == serial:
                    return msg[2] if msg[0] == "layers" else None
        except (EOFError, OSError):
            return None

    def close(self) -> None:
        """Stop the child (asked first, then killed) and wait for it."""
        if self.proc is not None:
            stop_child(self.proc, self.conn)
            self.proc = None


def unpack(layers: list, packed: dict) -> list:
    """``layers`` (the drag's start layers) with the child's moved layers put in."""
    out = list(layers)
    for k, f in packed.items():
        out[k] = dataclasses.replace(out[k], **f)
    return out

