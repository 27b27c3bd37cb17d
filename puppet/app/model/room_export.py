"""File > Export dressing room (issue 34): the open scene as the mannequin and the garment
scenes chosen, written by ``puppet dressroom`` in a child process (its own EGL context,
as File > Export's child: no GL is shared with the window).

The open scene as it is now (unsaved edits too) is written to a temporary folder
(``App.write_copy``) and named as the mannequin; the garments are scene files on the same
canvas. The child's one line, its success or its one-line refusal, is the message.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field


@dataclass
class RoomExport:
    """The dialog's fields and one run (window thread: :meth:`start`; read the fields)."""

    garments: list[str] = field(default_factory=list)
    adding: str = ""  # the garment path being typed
    output: str = ""
    state: str = "idle"  # idle | preparing | running | done | failed
    message: str = ""
    proc: subprocess.Popen | None = None
    written: str = ""  # the output of the run
    _tmp: str | None = None

    @property
    def running(self) -> bool:
        return self.state in ("preparing", "running")

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
        self.state, self.message = "preparing", ""
        self._tmp = tempfile.mkdtemp(prefix="puppet-room-")
        out = os.path.abspath(os.path.expanduser(self.output.strip()))
        out += os.sep if self.output.strip().endswith(("/", os.sep)) else ""
        self.written = out

        def then(path):  # on the scene thread: the mannequin as it is now, written to tmp
            if path is None:
                self.state, self.message = "failed", "no scene is open"
                return
            self._launch(path, out)
        app.write_copy(self._tmp, then)

    def _launch(self, mannequin: str, out: str) -> None:
        cmd = [sys.executable, "-m", "puppet", "dressroom", mannequin, *self.garments, "-o", out]
        env = dict(os.environ)
        env.pop("DISPLAY", None)  # EGL only in the child
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self.state = "running"
        threading.Thread(target=self._read, name="puppet-room", daemon=True).start()

    def _read(self) -> None:
        started = time.monotonic()
        _, err = self.proc.communicate()
        lines = [ln for ln in err.splitlines() if ln.strip()]
        if self.proc.returncode == 0:
            self.state = "done"
            self.message = (f"dressing room of {len(self.garments)} garment{'s' * (len(self.garments) != 1)} "
                            f"written to {self.written} ({time.monotonic() - started:.1f} s)")
        else:
            self.state = "failed"
            self.message = (lines[-1] if lines else f"puppet dressroom stopped (exit {self.proc.returncode})"
                            ).removeprefix("puppet: error: ")
        shutil.rmtree(self._tmp or "", ignore_errors=True)

    def wait(self, timeout: float = 120.0) -> bool:
        """Block until the run ends (tests); False on timeout."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if not self.running:
                return True
            time.sleep(0.05)
        return False


def form(app) -> RoomExport:
    f = app.__dict__.get("room_export")
    if f is None:
        f = app.__dict__["room_export"] = RoomExport()
    return f
