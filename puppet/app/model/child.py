"""A puppet command run in a child process on a copy of the open scene (File > Export,
File > Export dressing room).

The scene as it is now (unsaved edits too) is written to a temporary folder
(``App.write_copy``: paths relative to it, the scene's own files untouched); the child
draws offscreen (EGL, its own GL context: no GL is shared with the window, whose context
may be GLX under X). Its last line on stderr, its one-line refusal, is the message of a
failed run; the temporary folder goes when it ends.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import threading
import time


class ChildRun:
    """One run (window thread: :meth:`begin`; read the fields). Subclasses give the
    message of a success (:meth:`succeeded`) and may read the child's stdout
    (:meth:`read_stdout`, a line at a time)."""

    def __init__(self):
        self.proc: subprocess.Popen | None = None
        self.state = "idle"  # idle | preparing | running | done | failed | cancelled
        self.message = ""
        self.started = 0.0
        self._tmp: str | None = None

    @property
    def running(self) -> bool:
        return self.state in ("preparing", "running")

    def begin(self, app, prefix: str, command) -> None:
        """Write ``app``'s scene to a temporary folder, then run ``command(scene_path)``
        (an argv) in a child on a thread of its own."""
        self.state, self.message = "preparing", ""
        self.started = time.monotonic()
        tmp = self._tmp = tempfile.mkdtemp(prefix=prefix)

        def then(path):  # on the scene thread: the scene as it is now, written to tmp
            if path is None:
                self.state, self.message = "failed", "no scene is open"
                return
            env = dict(os.environ, PYTHONUNBUFFERED="1")
            env.pop("DISPLAY", None)  # EGL only in the child
            self.proc = subprocess.Popen(command(path), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                         env=env)
            self.state = "running"
            threading.Thread(target=self._read, name=f"{prefix}child", daemon=True).start()
        app.write_copy(tmp, then)

    def read_stdout(self, line: str) -> None:
        """A line the child printed (nothing by default)."""

    def succeeded(self) -> str:
        """The message of a run that ended well."""
        return "done"

    def _read(self) -> None:
        proc = self.proc
        for line in proc.stdout:
            self.read_stdout(line)
        err = proc.stderr.read().strip().splitlines()
        code = proc.wait()
        if self.state == "cancelled":
            pass
        elif code == 0:
            self.state, self.message = "done", self.succeeded()
        else:
            self.state = "failed"
            last = next((ln for ln in reversed(err) if ln.strip()), f"the child stopped (exit {code})")
            self.message = last.removeprefix("puppet: error: ")
        shutil.rmtree(self._tmp or "", ignore_errors=True)

    def wait(self, timeout: float = 120.0) -> bool:
        """Block until the run ends (tests); False on timeout."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if not self.running and (self.proc is None or self.proc.poll() is not None):
                time.sleep(0.05)  # the reader thread sets the final state after the exit
                if not self.running:
                    return True
            time.sleep(0.05)
        return False
