"""The drag solver child's side: the ``python`` that :class:`~puppet.scene.drag.process.DragProcess`
starts runs :func:`child_main`, which keeps a copy of the document (and its rig's cache,
from drag to drag) and serves the parent's drag with the same
:class:`~puppet.scene.drag.session.DragSession` code, so its previews are the parent's own
bit for bit. It lives here, not beside ``DragProcess``, because it makes a whole
:class:`~puppet.scene.document.core.Document`.
"""
from __future__ import annotations

from puppet.scene.document.core import Document
from puppet.scene.drag.child import child_setup, messages
from puppet.scene.rig import disk

#: LayerResult fields sent back per moved layer (``rest``, ``triangles`` and ``pins`` too
#: for a layer drawn as the coarse mesh of a reduced model, see :mod:`puppet.scene.rig.reduced`).
FIELDS = ("deformed", "depth", "exterior")


def child_main(fd: int) -> None:
    """The child: ``python -c "...child_main(FD)"`` with one end of a socket pair."""
    conn = child_setup(fd)
    rig, session = None, None
    for msg in messages(conn):
        try:
            if msg[0] == "open":
                rig, session = _open(rig, *msg[1:])
                conn.send(("ready", msg[1]))
            elif msg[0] == "move":
                conn.send(("layers", msg[1], pack(session, session.move_layers(msg[2], msg[3]))))
        except Exception as e:  # noqa: BLE001 - reported; the parent solves itself then
            session = None
            conn.send(("error", msg[1], f"{type(e).__name__}: {e}"))


def _open(rig, serial: int, doc: dict, file: str, active: str, names, time, record, iterations):
    d = Document(doc, file)
    if rig is not None:
        d.rig = rig  # content-keyed: every part built for an earlier version is reused
    else:  # the parts the app built are on disk beside the scene (when it has been saved)
        d.rig.memo.disk = disk.beside(file)
    d._set(doc, active, build=False)
    return d.rig, d.drag(names, time, record=record, iterations=iterations)


def pack(session, layers) -> dict:
    """{layer index: changed fields} of the layers of the groups a move re-solves."""
    built = session._built
    out = {}
    for k, r in enumerate(layers):
        if r.group not in session._moved:
            continue
        f = {name: getattr(r, name) for name in FIELDS}
        if r.rest is not built.meshes[k].V:  # a coarse mesh (a reduced model's)
            f.update(rest=r.rest, triangles=r.triangles, pins=r.pins)
        out[k] = f
    return out
