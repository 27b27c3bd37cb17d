"""Issue 23's gestures in the headless window: starch pins (drawn, never a pose target),
click / Shift+click selection, Alt-drag selects and turns, Esc or Ctrl+Z cancel a drag,
mode keys ignored while a button is held."""
from __future__ import annotations

import math

import numpy as np
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


@pytest.fixture
def bar_app(make_scene):
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}))
    yield d
    d.close()


def in_bend(d):
    """The bar app showing pose 'bend'; returns (driver, app)."""
    d.app.edit(lambda s: s.set_active_pose("bend"))
    d.settle()
    return d, d.app


def test_click_selects_only_that_pin_shift_click_adds_and_removes(bar_app):
    d = bar_app
    app = d.app
    d.click(*d.pin_screen("left"))
    d.click(*d.pin_screen("right"), mods=key.MOD_SHIFT)
    assert app.selection == ["left", "right"]
    d.click(*d.pin_screen("right"))  # a plain click on a pin of the selection: only it
    assert app.selection == ["right"]
    d.click(*d.pin_screen("left"), mods=key.MOD_SHIFT)  # Shift+click adds (not removes)
    assert app.selection == ["right", "left"]
    d.click(*d.pin_screen("left"), mods=key.MOD_SHIFT)  # and takes out
    assert app.selection == ["right"]
    # Pin mode: the same
    d.key(key._1)
    d.settle()
    d.click(*d.pin_screen("left"), mods=key.MOD_SHIFT)
    assert app.selection == ["right", "left"]
    d.click(*d.pin_screen("left"))
    d.settle()
    assert app.selection == ["left"] and len(d.scene().data.pins) == 2


@pytest.mark.parametrize("record", [False, True])
def test_on_the_timeline_a_click_selects_only_that_pin(bar_app, record):
    """The key drag and record tools (the canvas while the timeline shows the animation)
    select as the pose tool does: after a multi-pin drag, a plain click leaves only that
    pin, so the next Shift+press adds a pin instead of taking one out (which left nothing
    to drag)."""
    d = bar_app
    app = d.app
    app.timeline.scrub(0.5)
    app.timeline.record = record
    d.settle()
    d.click(*d.pin_screen("left"))
    d.click(*d.pin_screen("right"), mods=key.MOD_SHIFT)
    assert app.selection == ["left", "right"]
    d.click(*d.pin_screen("left"))
    assert app.selection == ["left"]
    app.timeline.record = False
    x, y = d.pin_screen("right")
    d.drag_path([(x, y), (x, y + 5), (x, y + 8)], mods=key.MOD_SHIFT)
    d.settle()
    assert app.selection == ["left", "right"] and "key left, right at 0.5 s" in app.status.text


def test_drag_of_a_selected_pin_moves_the_selection(bar_app):
    d, app = in_bend(bar_app)
    d.click(*d.pin_screen("left"))
    d.click(*d.pin_screen("right"), mods=key.MOD_SHIFT)
    x, y = d.pin_screen("right")
    s = app.view.scale
    d.drag_path([(x, y), (x, y + 5), (x, y + 10 * s)])
    d.settle()
    pose = d.scene().data.poses["bend"]
    assert app.selection == ["left", "right"]
    assert pose["left"].to[1] == pytest.approx(30, abs=0.6) and pose["right"].to[1] == pytest.approx(15, abs=0.6)


def test_alt_drag_selects_the_pin_it_turns(bar_app):
    d, app = in_bend(bar_app)
    d.click(*d.pin_screen("left"))
    c = d.pin_screen("right")
    path = [(c[0] + 40 * math.cos(t), c[1] - 40 * math.sin(t)) for t in np.linspace(0, math.pi / 2, 7)]
    d.drag_path(path, mods=key.MOD_ALT)
    d.settle()
    assert app.selection == ["right"]
    assert d.scene().data.poses["bend"]["right"].angle == pytest.approx(90.0, abs=0.5)


@pytest.mark.parametrize("cancel", ["esc", "ctrl+z"])
def test_esc_or_ctrl_z_during_a_drag_cancels_it(bar_app, cancel):
    d, app = in_bend(bar_app)
    scene = d.scene()
    before, steps = scene.to_dict(), len(scene.history.undo_stack)
    x, y = d.pin_screen("right")
    d.press(x, y)
    for k in range(1, 6):
        d.drag(x - 6 * k, y + 4 * k)
    d.settle()
    assert app.overrides  # the pin follows the pointer
    d.key(key.ESCAPE) if cancel == "esc" else d.key(key.Z, key.MOD_CTRL)
    d.drag(x - 40, y + 30)  # the pointer goes on moving: nothing follows it
    d.release(x - 40, y + 30)
    d.settle()
    assert scene.to_dict() == before and len(scene.history.undo_stack) == steps
    assert not app.overrides and "cancelled" in app.status.text
    np.testing.assert_allclose(d.pin_screen("right"), d.screen_of((100, 5)), atol=1.0)  # drawn as before
    # and a turn: Esc takes it back, no undo step
    c = d.pin_screen("right")
    d.press(c[0] + 40, c[1], mods=key.MOD_ALT)
    for t in np.linspace(0, math.pi / 2, 6)[1:]:
        d.drag(c[0] + 40 * math.cos(t), c[1] - 40 * math.sin(t), mods=key.MOD_ALT)
    d.settle()
    assert scene.data.poses["bend"]["right"].angle != 0
    d.key(key.ESCAPE)
    d.release(mods=key.MOD_ALT)
    d.settle()
    assert scene.to_dict() == before and len(scene.history.undo_stack) == steps


def test_mode_keys_wait_while_a_button_is_held(bar_app):
    d = bar_app
    app = d.app
    x, y = d.pin_screen("right")
    d.press(x, y)
    d.drag(x, y + 10)
    d.key(key.TAB)
    d.key(key._1)
    assert app.mode == "pose"
    d.drag(x, y + 20)
    d.release(x, y + 20)
    d.settle()
    pose = d.scene().active_pose
    assert app.mode == "pose" and pose != "rest" and "right" in d.scene().data.poses[pose]
    d.key(key.TAB)  # released: the key works again
    assert app.mode == "pin"
