"""File > Export dressing room (issue 34): the open scene as the mannequin and the garment
scenes chosen, written by ``puppet dressroom`` in a child process
(:class:`~puppet.app.model.child.ChildRun`, as File > Export's).

The open scene as it is now (unsaved edits too) is the mannequin; the garments are scene
files on the same canvas. The child's success or its one-line refusal is the message.
"""
from __future__ import annotations

import os
import sys
import time

from puppet.app.model.child import ChildRun


class RoomExport(ChildRun):
    """The dialog's fields and one run (window thread: :meth:`start`; read the fields)."""

    def __init__(self):
        super().__init__()
        self.garments: list[str] = []
        self.adding = ""  # the garment path being typed
        self.output = ""
        self.written = ""  # the output of the run

    def add(self, path: str) -> str | None:
        """Add a garment scene; the reason it is not added, or None."""
        path = os.path.abspath(os.path.expanduser(path.strip()))
        if not path.lower().endswith(".json") or not os.path.isfile(path):
            return f"{path}: not a scene file (.json)"
        if path in self.garments:
            return f"{os.path.basename(path)} is in the list already"
        self.garments.append(path)
        return None

    def start(self, app) -> None:
        """Write the room of ``app``'s scene and the garments to :attr:`output`."""
        if self.running or not self.garments or not self.output.strip():
            return
        out = os.path.abspath(os.path.expanduser(self.output.strip()))
        out += os.sep if self.output.strip().endswith(("/", os.sep)) else ""
        self.written = out
        self.begin(app, "puppet-room-",
                   lambda mannequin: [sys.executable, "-m", "puppet", "dressroom", mannequin, *self.garments, "-o", out])

    def succeeded(self) -> str:
        n = len(self.garments)
        return f"dressing room of {n} garment{'s' * (n != 1)} written to {self.written} " \
               f"({time.monotonic() - self.started:.1f} s)"


def form(app) -> RoomExport:
    f = app.__dict__.get("room_export")
    if f is None:
        f = app.__dict__["room_export"] = RoomExport()
    return f
