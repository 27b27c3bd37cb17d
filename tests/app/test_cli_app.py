"""`puppet app` on the command line: imported lazily (render and mesh never load pyglet or
ImGui), and a clear error without a display."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import ROOT, SCENES

CODE = f"""
import sys
from puppet.cli import main
assert main(["mesh", {SCENES + '/strips.json'!r}, "-o", sys.argv[1]]) == 0
assert main(["render", {SCENES + '/strips.json'!r}, "-o", sys.argv[2]]) == 0
print(','.join(sorted(m for m in sys.modules if m.split('.')[0] in ('pyglet', 'imgui_bundle')
                      or m.startswith('puppet.app'))))
"""


@pytest.mark.gl  # renders (in a subprocess)
def test_render_and_mesh_never_load_the_app(tmp_path):
    r = subprocess.run([sys.executable, "-c", CODE, str(tmp_path / "m.json"), str(tmp_path / "r.png")],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ""


def test_app_without_a_display_says_so():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = subprocess.run([sys.executable, "-m", "puppet", "app", SCENES + "/strips.json"], capture_output=True,
                       text=True, env=env, cwd=ROOT)
    assert r.returncode == 2 and r.stderr.startswith("puppet: error: puppet app needs a display")
    assert "Traceback" not in r.stderr


def _app(path, cwd, display=True):
    env = dict(os.environ, PYTHONPATH=ROOT)
    if not display:
        env = {k: v for k, v in env.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    return subprocess.run([sys.executable, "-m", "puppet", "app", str(path)], capture_output=True, text=True,
                          env=env, cwd=str(cwd), timeout=120)


@pytest.mark.slow
def test_app_on_a_file_it_cannot_open_fails_before_any_window(tmp_path):
    """Missing, a corrupt picture, an invalid scene, a folder: one line and exit 2, checked
    before the display (no display here: a window would fail differently)."""
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    (tmp_path / "text.png").write_text("not a png")
    (tmp_path / "bad.json").write_text('{"puppet": 1, "layers": [{"name": "a", "image": "gone.png"}]}')
    (tmp_path / "typo.json").write_text('{"puppet": 1, "layers": [], "canvass": [1, 1]}')
    (tmp_path / "bad.psd").write_bytes(b"8BPS truncated")
    from tests.conftest import bar_image, write_rgba

    write_rgba(tmp_path / "typo.png", bar_image())  # a good picture, but typo.json is beside it
    cases = {"missing.json": "no such file", "bad.png": "bad.png", "text.png": "not an image file",
             "bad.json": "gone.png", "typo.json": "canvass", "bad.psd": "bad.psd", ".": "not a file",
             "typo.png": "typo.json exists beside the picture"}
    for name, words in cases.items():
        r = _app(tmp_path / name, tmp_path, display=False)
        assert r.returncode == 2, (name, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("puppet: error: "), (name, r.stderr)
        assert words in lines[0] and "display" not in lines[0], (name, r.stderr)
        assert "Traceback" not in r.stderr and r.stdout == ""
    assert sorted(os.listdir(tmp_path)) == ["bad.json", "bad.png", "bad.psd", "text.png", "typo.json",
                                          "typo.png"]  # nothing written


def test_app_on_a_good_file_gets_as_far_as_the_display(tmp_path):
    """A scene that opens passes the check: without a display the next line is the display's."""
    r = _app(SCENES + "/strips.json", tmp_path, display=False)
    assert r.returncode == 2 and "needs a display" in r.stderr
