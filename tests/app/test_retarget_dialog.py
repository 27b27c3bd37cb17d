"""File > Retarget motion (issue 35) in a headless window: a BVH path typed, Read finds
the map and shows it beside the pins, a pair corrected, Write keys replaces the animation
in one undo step with keys that follow the corrected map; a bad clip is said in the
dialog and changes nothing."""
from __future__ import annotations

import os

import numpy as np
import pytest
from pyglet.window import key

from puppet.app.model import retarget as rt
from puppet.app.ui.actions import ACTIONS
from puppet.motion.bvh import read_bvh
from puppet.motion.retarget import retarget
from tests.app.harness import Driver, widget

pytestmark = pytest.mark.gl

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CHARACTER = os.path.join(ROOT, "assets", "scenes", "character.json")
WAVE = os.path.join(ROOT, "assets", "motion", "wave.bvh")


@pytest.fixture
def d(tmp_path):
    import puppet

    path = str(tmp_path / "character.json")
    puppet.load_scene(CHARACTER).save(path, copy=True)
    drv = Driver(path, size=(1280, 900))
    yield drv
    drv.close()


def steps(d) -> int:
    return len(d.scene().history.undo_stack)


def open_dialog(d) -> None:
    next(a for a in ACTIONS if a.name == "retarget").run(d.app, d.w)
    d.frame(3)
    assert d.app.dialog == "retarget"


def test_a_clip_read_mapped_corrected_and_written(d, tmp_path):
    d.settle()
    n0 = steps(d)
    open_dialog(d)
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT hips\n{\n")
    d.click(*widget("retarget:path"))
    d.type(str(bad))
    d.key(key.ENTER)
    d.frame(3)
    f = rt.form(d.app)
    assert f.motion is None and "bad.bvh" in f.error and steps(d) == n0
    d.click(*widget("retarget:path"))
    d.key(key.A, key.MOD_CTRL)
    d.type(WAVE)
    d.click(*widget("Read##retarget"))
    d.frame(3)
    assert f.motion is not None and not f.error
    assert set(f.map) == {p.name for p in d.scene().data.pins}
    assert {f.map["hand_l"], f.map["hand_r"]} == {"LeftHand", "RightHand"}  # hands to hands
    for pin in f.map:
        widget(f"retarget:joint:{pin}")  # each pin's joint is shown beside it
    f.map["hand_l"] = "RightForeArm"  # a pair corrected (what the pin's combo sets)
    f.map["head"] = rt.NONE  # and a pin left out
    d.click(*widget("Write keys"))
    d.settle()
    assert d.app.dialog is None and steps(d) == n0 + 1
    assert d.scene().history.undo_stack[-1].label == "retarget wave.bvh"
    anim = d.scene().to_dict()["animation"]
    keyed = set().union(*(k["pins"] for k in anim["keys"]))
    assert "head" not in keyed and {"hand_l", "foot_r"} <= keyed
    # the keys follow the corrected map: the same targets as the module with that map
    pins = {p.name: p.at for p in d.scene().data.pins}
    mapping = {p: j for p, j in f.map.items() if j != rt.NONE}
    r = retarget(read_bvh(WAVE), pins, mapping=mapping)
    last = anim["keys"][-1]
    np.testing.assert_allclose(last["pins"]["hand_l"], r.targets["hand_l"][-1], atol=1e-3)
    d.app.undo()
    d.settle()
    assert d.scene().to_dict()["animation"]["keys"][1]["pose"] == "wave"  # the character's own keys again
