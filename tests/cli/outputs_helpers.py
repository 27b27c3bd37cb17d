"""Shared by the output-safety tests: the real CLI in a subprocess, folder snapshots, mounts."""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import ROOT, bar_image, bar_scene, write_rgba


def cli(*args, timeout=120) -> subprocess.CompletedProcess:
    """``python -m puppet ARGS`` in a fresh process, as a user runs it."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "puppet", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=ROOT)


def snapshot(*folders) -> dict[str, str]:
    """Every file and folder (hidden ones too) under ``folders`` -> sha1 of its bytes ('dir' for folders)."""
    out = {}
    for top in folders:
        top = str(top)
        for dirpath, dirnames, filenames in os.walk(top):
            for d in dirnames:
                out[os.path.join(dirpath, d)] = "dir"
            for f in filenames:
                p = os.path.join(dirpath, f)
                if os.path.islink(p) and not os.path.exists(p):
                    out[p] = "dangling"
                    continue
                with open(p, "rb") as fh:
                    out[p] = hashlib.sha1(fh.read()).hexdigest()
    return out


def one_error_line(r: subprocess.CompletedProcess) -> str:
    """Assert exit status 2, exactly one stderr line ``puppet: error: ...``, no traceback; return it."""
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("puppet: error: "), lines[0]
    assert "Traceback" not in r.stderr
    return lines[0]


def make_bar(folder, *, mask=False, source=False, background=False, seconds=1.0, fps=10) -> str:
    """The bar scene in ``folder`` (optionally with a mask file, a source and a background image)."""
    os.makedirs(folder, exist_ok=True)
    s = bar_scene()
    write_rgba(os.path.join(folder, "bar.png"), bar_image())
    if mask:
        m = np.zeros((40, 120, 4), np.uint8)
        m[10:30, 10:110] = 255
        write_rgba(os.path.join(folder, "mask.png"), m)
        s["layers"][0]["mask"] = {"file": "mask.png"}
    if source:
        write_rgba(os.path.join(folder, "source.png"), bar_image(colour=(20, 90, 200)))
        s["source"] = "source.png"
        s["layers"].append({"name": "copy", "mask": {"rect": [10, 10, 100, 20]}})
    if background:
        write_rgba(os.path.join(folder, "bg.png"), np.full((40, 120, 4), (240, 230, 200, 255), np.uint8))
        s["background"] = "bg.png"
    s["animation"] = {"fps": fps, "keys": [{"time": 0, "pose": "rest"}, {"time": seconds, "pose": "bend"}]}
    path = os.path.join(folder, "scene.json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def fill(where: str) -> None:
    """Write zeros to ``where/filler`` until the disk holding it is full."""
    fd = os.open(os.path.join(where, "filler"), os.O_WRONLY | os.O_CREAT)
    try:
        while os.write(fd, b"\0" * 4096):
            pass
    except OSError:
        pass
    finally:
        os.close(fd)


class Mount:
    """A small tmpfs mounted for one test (root only); skips when mounting is not allowed."""

    def __init__(self, where, size="1m"):
        self.where = str(where)
        os.makedirs(self.where, exist_ok=True)
        if shutil.which("mount") is None:
            pytest.skip("no mount command")
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", self.where],
                           capture_output=True, text=True)
        if r.returncode:
            pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")

    def read_only(self):
        r = subprocess.run(["mount", "-o", "remount,ro", self.where], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr

    def fill(self):
        """Leave no free byte: write zeros until the disk is full."""
        fill(self.where)

    def close(self):
        subprocess.run(["umount", "-l", self.where], capture_output=True)


@pytest.fixture
def bounded():
    """Fail a test that runs in this process for more than 120 s (a hang), instead of waiting for ever."""
    import signal

    def stop(signum, frame):
        raise TimeoutError("the test ran for more than 120 s")
    old = signal.signal(signal.SIGALRM, stop)
    signal.alarm(120)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)
