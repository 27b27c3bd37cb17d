"""`puppet app` on the command line: imported lazily (render and mesh never load pyglet or
ImGui), and a clear error without a display."""
from __future__ import annotations

import os
import subprocess
import sys

from tests.conftest import ROOT, SCENES

CODE = f"""
import sys
from puppet.cli import main
assert main(["mesh", {SCENES + '/strips.json'!r}, "-o", sys.argv[1]]) == 0
assert main(["render", {SCENES + '/strips.json'!r}, "-o", sys.argv[2]]) == 0
print(','.join(sorted(m for m in sys.modules if m.split('.')[0] in ('pyglet', 'imgui_bundle')
                      or m.startswith('puppet.app'))))
"""


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


BAD_OPEN = """
import sys
import puppet.app
from puppet.errors import SceneError
try:
    puppet.app.run(sys.argv[1], headless=True)
except SceneError as e:
    print(f"puppet: error: {e}", file=sys.stderr)
    sys.exit(2)
"""


def test_app_on_a_file_it_cannot_open_says_so_and_quits(tmp_path):
    """As `puppet app bad.png` does (the CLI prints the SceneError and exits 2): the window
    closes at once with the one-line error, for a missing scene, a scene with a missing
    image and a file that is not a picture."""
    (tmp_path / "bad.png").write_text("not a png")
    (tmp_path / "bad.json").write_text('{"puppet": 1, "layers": [{"name": "a", "image": "nope.png"}]}')
    cases = {"missing.json": "no such scene file", "bad.json": "nope.png", "bad.png": "not an image file"}
    for name, words in cases.items():
        r = subprocess.run([sys.executable, "-c", BAD_OPEN, str(tmp_path / name)], capture_output=True, text=True,
                           cwd=ROOT, timeout=120)
        assert r.returncode == 2, (name, r.stderr)
        line = r.stderr.strip()
        assert line.startswith("puppet: error: ") and words in line and name in line and "\n" not in line, line
