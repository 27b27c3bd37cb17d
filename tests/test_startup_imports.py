"""Every `puppet` command pays for what it imports: the heavy modules a command does not
use stay out of it (issue 31, start-up).

Each check runs a fresh interpreter and reads its ``sys.modules`` at the end. The
modules named here were made lazy; a new top-level import of one of them fails a test.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import cv2
import numpy as np
import pytest

import puppet.deform
from puppet.scene.rig.links import _grown
from tests.conftest import ASSETS, SCENES

#: What no command needs once its scene's parts are on disk: SciPy's graph searches (which
#: load scipy.sparse.linalg and scipy.linalg), OpenCV outside drawing, GL outside drawing.
NOT_WARM = ("scipy.sparse.csgraph", "scipy.sparse.linalg", "scipy.linalg", "scipy.spatial", "cv2",
            "moderngl")
#: Deformers that only scenes of their own kind load (a method, pin angles, acceleration).
RARE_DEFORMERS = ("puppet.deform.igarashi", "puppet.deform.skeleton", "puppet.deform.rotate",
                  "puppet.deform.anderson", "puppet.deform.mls_lines")
#: puppet's own modules that a scene loads only when it uses them (a command compiles every
#: module it imports when Python writes no bytecode, PYTHONDONTWRITEBYTECODE=1).
ON_USE = RARE_DEFORMERS + (
    "puppet.scene.document.split", "puppet.imaging.cutout",  # Layer via Cut
    "puppet.imaging.grabcut",  # GrabCut masks
    "puppet.geom.curvature",  # automatic exterior points
    "puppet.scene.time.inbetween", "puppet.deform.interp",  # times on the animation
    "puppet.imaging.frames",  # video scenes
    "puppet.render.layers",  # drawing
)

LOADED = """
import json, sys
{run}
heavy = {names!r}
print(json.dumps(sorted(m for m in sys.modules if m in heavy)))
"""


def loaded(run: str, names, env=None) -> list[str]:
    """Which of ``names`` a fresh interpreter has loaded after executing ``run``."""
    code = LOADED.format(run=run, names=tuple(names))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_the_command_line_module_loads_no_numpy():
    """``puppet --help``, a bad flag, ``puppet app``: argparse and puppet's light modules only."""
    assert loaded("import puppet.cli", ("numpy", "scipy", "cv2", "moderngl", "PIL")) == []


def test_the_api_loads_no_graph_search_linalg_opencv_gl_or_rare_deformer():
    names = NOT_WARM + ON_USE
    assert loaded("import puppet, puppet.cli, puppet.api", names) == []
    # the package's names are still all there, each the submodule's own object
    assert loaded("import puppet.deform", names) == []


def test_the_deform_package_resolves_every_name_on_first_use():
    for name in puppet.deform.__all__:
        obj = getattr(puppet.deform, name)
        module = sys.modules[f"puppet.deform.{puppet.deform._WHERE[name]}"]
        assert obj is getattr(module, name)
    assert set(puppet.deform.__all__) <= set(dir(puppet.deform))
    from puppet.deform import arap_solve, factor  # a name, and a submodule
    assert arap_solve is sys.modules["puppet.deform.arap"].arap_solve
    assert factor is sys.modules["puppet.deform.factor"]
    with pytest.raises(AttributeError):
        puppet.deform.no_such_deformer  # noqa: B018


@pytest.fixture
def trex(tmp_path):
    """The bundled T-rex (8 linked layers) copied with its pictures, so its disk cache is
    made in the test's own folder."""
    shutil.copytree(os.path.join(ASSETS, "trex"), tmp_path / "trex")
    (tmp_path / "scenes").mkdir()
    shutil.copy(os.path.join(SCENES, "trex-layers.json"), tmp_path / "scenes")
    return str(tmp_path / "scenes" / "trex-layers.json")


def test_a_mesh_from_the_disk_cache_loads_no_graph_search_opencv_or_gl(trex, tmp_path):
    """A first ``puppet mesh`` builds the scene (and keeps its parts on disk); a later one
    of another pose reads them and solves: neither SciPy's linalg nor OpenCV nor GL are
    loaded for it, and its meshes are those of a scene built from nothing."""
    run = "import puppet.cli; assert puppet.cli.main({argv!r}) == 0"

    def mesh(pose, out, cache):
        argv = ["mesh", trex, "--pose", pose, "-o", str(tmp_path / out)]
        return loaded(run.format(argv=argv), NOT_WARM + ON_USE, dict(os.environ, PUPPET_CACHE=cache))

    assert "scipy.sparse.csgraph" in mesh("roar", "first.json", "on")  # building searches graphs
    assert os.path.isdir(tmp_path / "scenes" / ".puppet-cache")
    assert mesh("wave", "warm.json", "on") == []  # (a pose that folds would untangle: roar)
    mesh("wave", "cold.json", "off")
    assert (tmp_path / "warm.json").read_text() == (tmp_path / "cold.json").read_text()


def reference_grown(mask):
    """What the link clipping grew masks with before: OpenCV's 3x3 dilation."""
    return cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


class Im:
    def __init__(self, mask):
        self.mask = mask


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (6, 1), (2, 2), (13, 17), (200, 300)])
def test_masks_are_grown_as_opencv_grew_them(shape):
    rng = np.random.default_rng(sum(shape))
    for fill in (0.0, 0.002, 0.05, 0.5, 1.0):
        mask = rng.random(shape) < fill
        got = _grown(Im(mask))
        assert got.dtype == bool and got.shape == mask.shape
        assert np.array_equal(got, reference_grown(mask)), (shape, fill)


def test_a_grown_mask_by_hand():
    m = np.zeros((4, 5), bool)
    m[0, 0] = m[3, 2] = True
    want = np.array([[1, 1, 0, 0, 0],
                     [1, 1, 0, 0, 0],
                     [0, 1, 1, 1, 0],
                     [0, 1, 1, 1, 0]], bool)
    assert np.array_equal(_grown(Im(m)), want)
