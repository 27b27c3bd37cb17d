"""geom, deform, imaging and scene never import moderngl or pyglet (nor render/app)."""
import subprocess
import sys

from tests.conftest import SCENES

CODE = f"""
import sys
import puppet.geom.contour, puppet.geom.triangulate, puppet.geom.merge, puppet.geom.laplacian, puppet.geom.geodesic
import puppet.deform, puppet.imaging.io, puppet.imaging.masks, puppet.imaging.inpaint
import puppet.scene.document.core
doc = puppet.scene.document.core.Document.load({SCENES + '/trex-layers.json'!r})
doc.layers('wave'); doc.mesh('tuck')
bad = sorted(m for m in sys.modules if m.split('.')[0] in ('moderngl', 'pyglet', 'glcontext')
             or m.startswith(('puppet.render', 'puppet.app', 'puppet.anim')))
print(','.join(bad))
"""


def test_numerical_layers_import_no_gl():
    r = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ""


def test_import_contracts_with_import_linter():
    import os
    import shutil

    import pytest
    exe = shutil.which("lint-imports") or os.path.join(os.path.dirname(sys.executable), "lint-imports")
    if not os.path.exists(exe):
        pytest.skip("lint-imports (import-linter, a test extra: pip install -e '.[test]') is not installed")
    r = subprocess.run([exe], capture_output=True, text=True, cwd=os.path.dirname(os.path.dirname(__file__)))
    assert r.returncode == 0, r.stdout[-2000:]
    assert "0 broken" in r.stdout


APP_MODEL = """
import os, sys, importlib
for room in ("model", "tools"):
    folder = os.path.join("puppet", "app", room)
    for f in sorted(os.listdir(folder)):
        if f.endswith(".py"):
            importlib.import_module(f"puppet.app.{room}" + ("" if f == "__init__.py" else "." + f[:-3]))
print(",".join(sorted(m for m in sys.modules if m.split('.')[0] in ('moderngl', 'pyglet', 'glcontext', 'imgui_bundle')
                      or m.startswith(('puppet.render', 'puppet.app.ui', 'puppet.app.gl')))))
"""


def test_app_model_and_tools_load_no_gl_window_or_imgui():
    """Every module of app/model and app/tools imported: no GL, window or ImGui library is
    loaded (the app's state and its tools run and test without them)."""
    import os
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    r = subprocess.run([sys.executable, "-c", APP_MODEL], capture_output=True, text=True, cwd=root)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ""
