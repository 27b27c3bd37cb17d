"""The T-rex and the dress in a 1280x800 headless app window, as a user sees them; the
screenshots of docs/app.md are taken here (docs/app/*.png, rewritten only when they change)."""
from __future__ import annotations

import os

import numpy as np
import pytest
from pyglet.window import key

from tests.app.harness import Driver, widget
from tests.conftest import ASSETS, SCENES

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def trex():
    d = Driver(os.path.join(SCENES, "trex-layers.json"), size=(1280, 800))
    yield d
    d.close()


def changed(a, b) -> int:
    return int((np.abs(a.astype(int) - b).sum(axis=2) > 30).sum())


def test_pose_mode_and_a_drag(trex):
    d = trex
    d.click(*widget("pose:wave"))
    d.settle()
    assert d.app.snap.active == "wave"
    d.move(*d.pin_screen("tail_tip"))
    d.frame(2)
    d.shot("pose-mode")
    a = d.pin_screen("hand_front")
    d.press(*a)
    for k in range(1, 6):
        d.drag(a[0] + 10 * k, a[1] - 14 * k)
        d.settle()  # every move solved in turn: the same preview every run
    assert d.app.snap.preview
    d.shot("drag-preview")
    d.release()
    d.settle()
    assert not d.app.snap.preview
    d.key(key.Z, key.MOD_CTRL)
    d.settle()


def test_pin_mode_mesh_and_links(trex):
    d = trex
    d.key(key._1)
    d.settle()
    plain = d.pixels()
    d.key(key.M)
    d.key(key.L)
    d.frame()
    d.shot("mesh-links")
    assert changed(d.pixels(), plain) > 20000
    # link segments are drawn in green where the scene links tail and body
    x, y = (int(v) for v in d.screen_of((360.5, 307.5)))
    patch = d.pixels()[y - 4:y + 5, x - 4:x + 5].reshape(-1, 3).astype(int)
    assert ((patch[:, 1] > 180) & (patch[:, 0] < 100)).any()
    d.key(key.M)
    d.key(key.L)


def test_depth_view(trex):
    d = trex
    d.key(key.D)
    d.frame()
    d.shot("depth-view")
    arm = d.pixels()[tuple(int(v) for v in d.screen_of((140, 255)))[::-1]].astype(int)
    body = d.pixels()[tuple(int(v) for v in d.screen_of((300, 330)))[::-1]].astype(int)
    assert arm[0] > arm[2] and body[2] > body[0]  # the front arm red, the body behind it blue
    d.key(key.D)


def test_layers_panel_and_keys(trex):
    d = trex
    d.click(*widget("layer:tail"))
    d.move(600, 780)  # off the panel: no tooltip
    d.frame(2)
    d.shot("layer-options")
    d.type("?")
    d.frame(2)
    d.shot("keys")
    d.key(key.ESCAPE)
    d.key(key._2)
    d.settle()


def test_reference_picture_under_a_garment():
    d = Driver(os.path.join(SCENES, "dress-garment.json"), size=(1280, 800))
    try:
        before = d.pixels()
        ref = os.path.join(ASSETS, "noto-emoji", "emoji_u1f3c3.png")
        d.app.edit(lambda s: s.set_underlay(ref, opacity=0.45, offset=(40, 0), scale=1.0))
        d.settle()
        d.click(*widget("pose:flare"))
        d.move(600, 790)
        d.settle()
        d.shot("reference-picture")
        assert changed(d.pixels(), before) > 5000
        assert d.scene().underlay["opacity"] == 0.45
    finally:
        d.close()
