"""SIGTERM in the middle of exporting the new formats (WebM, APNG, sprite sheet) leaves
no temporary file and no partial output, like GIF, MP4 and frame folders
(``tests/cli/test_signals.py``): the pipeline's threads stop before cleanup."""
from __future__ import annotations

import os
import signal
import time

import pytest

from tests.cli.outputs_helpers import make_bar, snapshot
from tests.cli.test_signals import _start, _wait_for_temp

pytestmark = pytest.mark.gl


@pytest.mark.parametrize("name", ["o.webm", "o.apng", "o.png"])
@pytest.mark.slow
def test_sigterm_mid_export_leaves_nothing(tmp_path, name):
    scene = make_bar(tmp_path / "s", seconds=1000.0)  # 10001 frames
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    inputs = snapshot(tmp_path / "s")
    proc = _start(scene, os.path.join(out_dir, name))
    try:
        # WebM holds its first bytes for hundreds of frames (38 s of the suite under load):
        # its temporary file made and frames on their way is mid-export enough
        _wait_for_temp(proc, out_dir, data=name != "o.webm")
        if name == "o.webm":
            time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGTERM, (proc.returncode, err)
    assert err.strip() == "puppet: stopped by SIGTERM"
    assert os.listdir(out_dir) == []
    assert snapshot(tmp_path / "s") == inputs
