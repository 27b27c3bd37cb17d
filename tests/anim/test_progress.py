"""animate_to's progress callback (what the app's exporter child prints), for a pixel and
a mesh format; no monkey-patching of the scene."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

import puppet
from puppet.anim.export import animate_to
from tests.cli.outputs_helpers import ROOT, make_bar

pytestmark = pytest.mark.gl


@pytest.mark.parametrize("name", ["a.gif", "a.html", "a.spine.json", "f/"])
def test_progress_callback_counts_every_frame(tmp_path, name):
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=1.0, fps=10))
    seen = []
    assert animate_to(scene, f"{tmp_path}/{name}", progress=lambda done, total: seen.append((done, total))) == 11
    assert seen == [(i, 11) for i in range(1, 12)]
    scene.close()


def test_app_exporter_child_prints_progress(tmp_path):
    scene = make_bar(tmp_path / "s", seconds=1.0, fps=10)
    out = tmp_path / "a.html"
    proc = subprocess.run([sys.executable, "-m", "puppet.anim.export_child", scene, str(out), json.dumps({"fps": 5})],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("progress")]
    assert lines[:6] == [f"progress {i} 6" for i in range(1, 7)] and out.exists()
