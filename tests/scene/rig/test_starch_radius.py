"""A starch pin's radius: every value the format allows (0 < radius <= 1e4) gives a
sensible stiffening and no warning (issue 30, case 9: 1e-300 printed numpy's
RuntimeWarning and a source line), through the API and through the command line; and
other tiny or huge values the format allows warn nothing either."""
from __future__ import annotations

import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

from puppet.scene.document.core import Document
from puppet.scene.rig.stiffness import _reach
from tests.conftest import bar_image, bar_scene
from tests.scene.document.test_edits import three_bars

RADII = [1e-300, 5e-324, 1e-160, 1e-3, 1.0, 40.0, 1e4]

#: other extreme values the format allows (each gave, or could give, a numpy warning)
EXTREMES = {
    "exterior beta 1e-300": lambda s: s["layers"][0].update(exterior={"beta": 1e-300}),
    "deformer alpha 1e-300": lambda s: s.update(deformer={"alpha": 1e-300}),
    "mls alpha 1e-300": lambda s: s.update(deformer={"alpha": 1e-300, "method": "mls"}),
    "link strength 1e-300": lambda s: s["links"][0].update(strength=1e-300),
    "fps 1e-300": lambda s: s["animation"].update(fps=1e-300),
    "key time 5e-324": lambda s: s["animation"]["keys"][1].update(time=5e-324),
    "target 5e-324": lambda s: s["poses"]["up"].update(a2=[1e-300, 5e-324]),
    "min_angle 1e-300": lambda s: s["layers"][0].update(mesh={"min_angle": 1e-300}),
    "angle 3600": lambda s: s["poses"]["up"].update(c1={"to": [150, 55], "angle": 3600}),
}


def starch_scene(radius: float) -> dict:
    scene = bar_scene()
    scene["pins"].append({"name": "s", "layer": "bar", "at": [60, 20], "kind": "starch", "radius": radius})
    return scene


@pytest.mark.parametrize("radius", RADII)
def test_every_allowed_radius_solves_without_a_warning(make_scene, radius):
    path = make_scene(starch_scene(radius), {"bar.png": bar_image()})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="raise"):
            doc = Document.load(path)
            layers = doc.layers("bend")
    assert all(np.isfinite(r.deformed).all() for r in layers)


def test_the_bump_is_the_formula_and_a_tiny_radius_stiffens_only_the_pin():
    V = np.array([[0.0, 0.0], [3.0, 4.0], [10.0, 0.0], [1e6, 0.0]])
    for r in (10.0, 5.0, 1e4):  # (1 - d^2 / r^2)^2 inside the reach, 0 outside
        d = np.hypot(V[:, 0], V[:, 1])
        expected = np.clip(1 - d ** 2 / r ** 2, 0, 1) ** 2
        np.testing.assert_allclose((1 - _reach(V, (0.0, 0.0), r) ** 2) ** 2, expected, rtol=0, atol=1e-15)
    with np.errstate(all="raise"):
        tiny = (1 - _reach(V, (0.0, 0.0), 1e-300) ** 2) ** 2
    np.testing.assert_array_equal(tiny, [1.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("name", sorted(EXTREMES))
def test_extreme_values_the_format_allows_warn_nothing(make_scene, name):
    scene = three_bars()
    EXTREMES[name](scene)
    path = make_scene(scene, {"bar.png": bar_image()})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        doc = Document.load(path)
        for layers in (doc.layers("up"), doc.layers(time=0.5), doc.layers(time=doc.duration())):
            assert all(np.isfinite(r.deformed).all() for r in layers)
        doc.summary()


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "puppet", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=60)


def test_the_command_line_prints_nothing_on_stderr(make_scene, tmp_path):
    path = make_scene(starch_scene(1e-300), {"bar.png": bar_image()})
    r = _cli("mesh", path, "--pose", "bend", "-o", str(tmp_path / "m.json"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""
    r = _cli("check", path, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""



@pytest.mark.slow  # four commands
def test_the_command_line_prints_nothing_for_the_other_extremes(make_scene, tmp_path):
    scene = three_bars()
    for name in ("exterior beta 1e-300", "deformer alpha 1e-300", "link strength 1e-300", "fps 1e-300"):
        EXTREMES[name](scene)
    path = make_scene(scene, {"bar.png": bar_image()})
    for args in (["mesh", path, "--time", "0.5", "-o", str(tmp_path / "m.json")], ["check", path]):
        r = _cli(*args, cwd=tmp_path)
        assert (r.returncode, r.stderr) == (0, "")


@pytest.mark.gl
def test_render_prints_nothing_on_stderr(make_scene, tmp_path):
    path = make_scene(starch_scene(1e-300), {"bar.png": bar_image()})
    r = _cli("render", path, "--pose", "bend", "-o", str(tmp_path / "o.png"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""
    assert os.path.getsize(tmp_path / "o.png") > 0
