"""geom, deform, imaging and scene never import moderngl or pyglet (nor render/app)."""
import subprocess
import sys

from tests.conftest import SCENES

CODE = f"""
import sys
import puppet.geom.contour, puppet.geom.triangulate, puppet.geom.merge, puppet.geom.laplacian, puppet.geom.geodesic
import puppet.deform, puppet.imaging.io, puppet.imaging.masks, puppet.imaging.inpaint
import puppet.scene.document
doc = puppet.scene.document.Document.load({SCENES + '/trex-layers.json'!r})
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
