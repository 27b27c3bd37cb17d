"""Change events and the undo history of an editable scene (no GL, no UI).

Events follow napari's style: a view connects a callback to ``scene.events`` and is
called with an :class:`Event` naming what changed, only when something really changed.
The history stores whole snapshots of the document (the scene JSON, a few kilobytes to
a few hundred), so undo can never disagree with what an edit did; a block of edits (a
whole drag) is recorded as one step.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

#: what an edit invalidates, cheapest first
LEVELS = ("none", "solve", "precompute", "mesh")


@dataclass(frozen=True)
class Event:
    """What changed: ``type`` is the edit's kind (``"pin"``, ``"layer"``, ``"link"``,
    ``"pose"``, ``"target"``, ``"active"``, ``"animation"``, ``"deformer"``, ``"undo"``,
    ``"redo"``, ``"drag"``), ``name`` the item (pin, layer or pose name, or ``""``),
    ``level`` the dirty level (one of :data:`LEVELS`), ``label`` words for a menu."""

    type: str
    name: str = ""
    level: str = "none"
    label: str = ""


class Events:
    """Callbacks subscribed to a scene's changes."""

    def __init__(self):
        self._callbacks: list[Callable[[Event], Any]] = []

    def connect(self, callback: Callable[[Event], Any]) -> Callable[[Event], Any]:
        """Call ``callback(event)`` after every real change; returns it (usable as a decorator)."""
        self._callbacks.append(callback)
        return callback

    def disconnect(self, callback: Callable[[Event], Any]) -> None:
        self._callbacks = [c for c in self._callbacks if c != callback]  # (a bound method is a new object each time)

    def emit(self, event: Event) -> None:
        for c in list(self._callbacks):
            c(event)


@dataclass
class Step:
    """One undoable step: the document before and after, and what it was."""

    label: str
    before: Any
    after: Any
    event: Event = field(default_factory=lambda: Event("scene"))


class History:
    """Undo and redo stacks of :class:`Step` with nested blocks (one step per outer block)."""

    def __init__(self, limit: int = 10000):
        self.limit = limit
        self.undo_stack: list[Step] = []
        self.redo_stack: list[Step] = []
        self._block: list[Any] = []  # snapshot at the start of each open block, and its label

    @property
    def in_block(self) -> bool:
        return bool(self._block)

    def open(self, snapshot: Any, label: str) -> None:
        self._block.append((snapshot, label))

    def close(self, snapshot: Any) -> Step | None:
        """End a block; the outermost one becomes one step if ``snapshot`` differs from
        the snapshot the block opened with."""
        before, label = self._block.pop()
        if self._block or snapshot == before:
            return None
        step = Step(label, before, snapshot, Event("scene", label=label))
        self.push(step)
        return step

    def push(self, step: Step) -> None:
        self.undo_stack.append(step)
        del self.undo_stack[:-self.limit]
        self.redo_stack.clear()

    def can_undo(self) -> bool:
        return bool(self.undo_stack) and not self._block

    def can_redo(self) -> bool:
        return bool(self.redo_stack) and not self._block
