"""Issue 23's gestures in the headless window: starch pins (drawn, never a pose target),
click / Shift+click selection, Alt-drag selects and turns, Esc or Ctrl+Z cancel a drag,
mode keys ignored while a button is held."""
from __future__ import annotations

import pytest
from pyglet.window import key

from tests.app.harness import Driver
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl


@pytest.fixture
def starch_app(make_scene):
    scene = bar_scene()
    scene["pins"].append({"name": "mid", "layer": "bar", "at": [60, 20], "kind": "starch", "radius": 20})
    d = Driver(make_scene(scene, {"bar.png": bar_image()}))
    yield d
    d.close()


def test_starch_pin_is_drawn_and_never_a_pose_target(starch_app):
    d = starch_app
    app = d.app
    assert app.mode == "pose" and app.marker("mid").kind == "starch"
    x, y = d.pin_screen("mid")
    px = d.pixels()[int(round(y)), int(round(x))]
    assert px.min() > 200  # the light grey square over the red bar (no KeyError drawing it)
    d.drag_path([(x, y), (x + 10, y - 10), (x + 20, y - 20)])
    d.settle()
    assert "mid" not in app.selection
    assert set(d.scene().data.poses) == {"bend"}  # no pose made by dragging a starch pin
    # selected in Pin mode (its rest position can move), it is left out of pose drags
    d.key(key._1)
    d.settle()
    d.click(x, y)
    d.settle()
    assert app.selection == ["mid"]
    d.key(key._2)
    d.settle()
    rx, ry = d.pin_screen("right")
    d.drag_path([(rx, ry), (rx, ry + 8), (rx, ry + 15)], mods=key.MOD_SHIFT)
    d.settle()
    pose = d.scene().data.poses[d.scene().active_pose]
    assert "right" in pose and "mid" not in pose
