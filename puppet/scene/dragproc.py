"""Drag previews solved in a child process, so that no solve holds the window's GIL.

A :class:`DragProcess` is a long-lived child (a fresh ``python``, one BLAS thread) that
keeps a copy of the scene and its built parts (its rig's cache survives from drag to
drag: only what an edit changed is rebuilt there). A drag session given one
(``doc.drag(names, solver=proc)``) sends it the document and the drag when it opens, the
targets on each move, and gets back the posed layers of the groups the move changed; the
thread that waits for them only waits on a socket, without the GIL. Until the child has
built the scene version (its first drag after an edit of the meshes), and whenever it is
not there, the session solves in its own thread instead. The child runs the very same
:class:`~puppet.scene.drag.DragSession` code on the same inputs, so its previews are the
in-thread ones bit for bit (a test checks it); the release is always solved by the
caller's own document, exactly.

``benchmarks/bench_solver.py`` measures this against a solver thread: with the machine
very busy (load 10-11), a 60 Hz window beside previews without pause was late by a median
1-3 ms with the process against 9-19 ms with a thread (p99 19-27 ms against 139-369 ms);
at load 5-7 the two varied from run to run (p99 13-39 ms against 12-76 ms).
"""
from __future__ import annotations

from puppet.scene.child import child_setup, start_child, stop_child

#: LayerResult fields sent back per moved layer (``rest``, ``triangles`` and ``pins`` too
#: for a layer drawn as a proxy mesh, see :mod:`puppet.scene.proxy`).
FIELDS = ("deformed", "depth", "exterior")


def child_main(fd: int) -> None:
    """The child: ``python -c "...child_main(FD)"`` with one end of a socket pair."""
    conn = child_setup(fd)
    rig, session = None, None
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        try:
            if msg[0] == "open":
                rig, session = _open(rig, *msg[1:])
                conn.send(("ready", msg[1]))
            elif msg[0] == "move":
                conn.send(("layers", msg[1], _pack(session, session.move_layers(msg[2], msg[3]))))
        except Exception as e:  # noqa: BLE001 - reported; the parent solves itself then
            session = None
            conn.send(("error", msg[1], f"{type(e).__name__}: {e}"))


def _open(rig, serial: int, doc: dict, file: str, active: str, names, time, record, iterations):
    from puppet.scene.document import Document

    d = Document(doc, file)
    if rig is not None:
        d.rig = rig  # content-keyed: every part built for an earlier version is reused
    d._set(doc, active, build=False)
    return d.rig, d.drag(names, time, record=record, iterations=iterations)


def _pack(session, layers) -> dict:
    """{layer index: changed fields} of the layers of the groups a move re-solves."""
    built = session._built
    out = {}
    for k, r in enumerate(layers):
        if r.group not in session._moved:
            continue
        f = {name: getattr(r, name) for name in FIELDS}
        if r.rest is not built.meshes[k].V:  # a proxy mesh
            f.update(rest=r.rest, triangles=r.triangles, pins=r.pins)
        out[k] = f
    return out


class DragProcess:
    """A child process that solves drag previews (see the module docstring).

    Use from one thread (the scene thread); :meth:`close` when done.
    """

    def __init__(self):
        self.proc, self.conn = start_child("puppet.scene.dragproc", "child_main", {
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
        """The child's packed preview of drag ``serial`` (see :func:`_pack`), or None."""
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
    import dataclasses

    out = list(layers)
    for k, f in packed.items():
        out[k] = dataclasses.replace(out[k], **f)
    return out

