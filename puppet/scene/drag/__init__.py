"""Dragging pins: one :class:`.session.DragSession` for every drag (pins of a pose, keyed
pins, record mode), warm-started previews of the moved groups and an exact release; a
child process that solves the previews (:mod:`.process`) over the plumbing of
:mod:`.child`.

Imports: ``scene.rig``, ``puppet.errors``; not ``scene.time``. The session is given its
document at run time; the child's own side, which makes a Document, is
:mod:`puppet.scene.document.drag_child`.
"""
