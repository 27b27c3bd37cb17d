"""File > Export: the scene's animation written by :func:`puppet.anim.export.animate_to`
in a child process, with its progress shown in the app.

The scene as it is now is written to a temporary folder and ``python -m
puppet.anim.export_child SCENE OUTPUT OPTIONS`` draws it offscreen
(:class:`~puppet.app.model.child.ChildRun`). The child prints ``progress I N`` lines; Cancel interrupts it (SIGINT)
and the export's atomic write leaves nothing behind.
"""
from __future__ import annotations

import json
import os
import signal
import sys
import time

from puppet.app.model.child import ChildRun


class Export(ChildRun):
    """One export run (window thread: :meth:`start`, :meth:`cancel`; read the fields)."""

    def __init__(self):
        super().__init__()
        self.done = 0
        self.total = 0
        self.output = ""

    def start(self, app, output: str, **options) -> None:
        """Export the scene of ``app`` to ``output``; ``options``: fps, start, end, background, size."""
        if self.running:
            return
        folder = output.endswith(("/", os.sep))
        self.output = os.path.abspath(os.path.expanduser(output)) + (os.sep if folder else "")
        self.done, self.total = 0, 0
        self.begin(app, "puppet-export-", lambda scene: [sys.executable, "-m", "puppet.anim.export_child", scene,
                                                         self.output, json.dumps(options)])

    def read_stdout(self, line: str) -> None:
        parts = line.split()
        if len(parts) == 3 and parts[0] == "progress":
            self.done, self.total = int(parts[1]), int(parts[2])

    def succeeded(self) -> str:
        return f"exported {self.done} frames to {self.output} in {time.monotonic() - self.started:.1f} s"

    def cancel(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.state = "cancelled"
            self.message = "export cancelled (nothing was written)"
            self.proc.send_signal(signal.SIGINT)

    def eta(self) -> str:
        if not self.done or not self.total:
            return ""
        el = time.monotonic() - self.started
        rate = self.done / el
        return f"{rate:.1f} frames/s, {max(self.total - self.done, 0) / rate:.0f} s left"
