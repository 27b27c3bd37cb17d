"""File > Export: the scene's animation written by :func:`puppet.anim.export.animate_to`
in a child process, with its progress shown in the app.

The scene as it is now (unsaved edits too) is written to a temporary folder
(:meth:`~puppet.scene.document.core.Document.to_json`: paths relative to it, the scene's own
files untouched), and ``python -m puppet.anim.export_child SCENE OUTPUT OPTIONS`` draws it
offscreen (EGL, its own GL context: no GL is shared with the window, whose context may
be GLX under X). The child prints ``progress I N`` lines; Cancel interrupts it (SIGINT)
and the export's atomic write leaves nothing behind.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time


class Export:
    """One export run (window thread: :meth:`start`, :meth:`cancel`; read the fields)."""

    def __init__(self):
        self.proc: subprocess.Popen | None = None
        self.done = 0
        self.total = 0
        self.state = "idle"  # idle | preparing | running | done | failed | cancelled
        self.message = ""
        self.output = ""
        self.started = 0.0
        self._tmp: str | None = None

    @property
    def running(self) -> bool:
        return self.state in ("preparing", "running")

    def start(self, app, output: str, **options) -> None:
        """Export the scene of ``app`` to ``output``; ``options``: fps, start, end, background, size."""
        if self.running:
            return
        folder = output.endswith(("/", os.sep))
        self.output = os.path.abspath(os.path.expanduser(output)) + (os.sep if folder else "")
        self.state, self.message, self.done, self.total = "preparing", "", 0, 0
        self.started = time.monotonic()
        tmp = self._tmp = tempfile.mkdtemp(prefix="puppet-export-")

        def then(path):  # on the scene thread: the scene as it is now, written to tmp
            if path is None:
                self.state, self.message = "failed", "no scene is open"
            else:
                self._launch(path, options)
        app.write_copy(tmp, then)

    def _launch(self, scene_path: str, options: dict) -> None:
        cmd = [sys.executable, "-m", "puppet.anim.export_child", scene_path, self.output, json.dumps(options)]
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        env.pop("DISPLAY", None)  # EGL only in the child
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self.state = "running"
        threading.Thread(target=self._read, name="puppet-export", daemon=True).start()

    def _read(self) -> None:
        proc = self.proc
        for line in proc.stdout:
            parts = line.split()
            if len(parts) == 3 and parts[0] == "progress":
                self.done, self.total = int(parts[1]), int(parts[2])
        err = proc.stderr.read().strip().splitlines()
        code = proc.wait()
        if self.state == "cancelled":
            pass
        elif code == 0:
            self.state = "done"
            self.message = f"exported {self.done} frames to {self.output} in {time.monotonic() - self.started:.1f} s"
        else:
            self.state = "failed"
            last = next((ln for ln in reversed(err) if ln.strip()), f"the export stopped (exit {code})")
            self.message = last.removeprefix("puppet: error: ")
        shutil.rmtree(self._tmp or "", ignore_errors=True)

    def cancel(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.state = "cancelled"
            self.message = "export cancelled (nothing was written)"
            self.proc.send_signal(signal.SIGINT)

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

    def eta(self) -> str:
        if not self.done or not self.total:
            return ""
        el = time.monotonic() - self.started
        rate = self.done / el
        return f"{rate:.1f} frames/s, {max(self.total - self.done, 0) / rate:.0f} s left"
