"""The canvas tools driven by synthetic pyglet events in a headless window: the model is
read back (pins where clicked, in canvas coordinates, through pan and zoom) and so are
the framebuffer's pixels."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pyglet.window import key, mouse

pytestmark = pytest.mark.gl


def pins(d):
    return {p.name: p for p in d.scene().data.pins}


def test_opens_in_pose_mode_with_the_canvas_fitted(bar_app):
    d = bar_app
    app = d.app
    assert app.mode == "pose" and app.snap.shown == "rest"
    x, y, w, h = app.view.canvas_rect(app.snap.canvas)
    ax, ay, aw, ah = app.area
    # fitted: the whole canvas inside the canvas area, centred, touching one margin pair
    assert ax <= x and x + w <= ax + aw and ay <= y and y + h <= ay + ah
    assert abs((x - ax) - (ax + aw - x - w)) <= 1.0
    assert d.ready["canvas"] == [x, y, w, h]
    px = d.pixels()
    bar_px = px[int(round(d.screen_of((60, 20))[1])), int(round(d.screen_of((60, 20))[0]))]
    assert np.abs(bar_px.astype(int) - (200, 40, 40)).max() <= 2  # the red bar
    corner = px[int(y + 3), int(x + 3)]
    assert corner.tolist() == [255, 255, 255]  # the white background
    outside = px[int(y + h + 5), int(x + w / 2)] if y + h + 5 < ay + ah else px[int(y + h / 2), int(ax + 2)]
    assert outside.max() < 80  # the dark surround
    assert app.title.startswith("puppet — scene.json") and not app.title.endswith("*")


def test_pin_added_where_clicked_through_pan_and_zoom(bar_app):
    d = bar_app
    app = d.app
    d.key(key._1)
    assert app.mode == "pin"
    d.settle()
    # zoom about the cursor: the canvas point under it stays put
    cursor = tuple(round(v) for v in d.screen_of((80, 25)))  # pointers live on whole pixels
    under = app.view.to_canvas(cursor)
    scale0 = app.view.scale
    d.scroll(*cursor, 2)
    assert app.view.scale == pytest.approx(scale0 * 1.2 ** 2)
    np.testing.assert_allclose(app.view.to_canvas(cursor), under, atol=1e-9)
    # pan with the middle button
    o0 = np.array(app.view.origin)
    d.drag_path([(500, 400), (520, 390), (530, 380)], button=mouse.MIDDLE)
    np.testing.assert_allclose(np.array(app.view.origin) - o0, (30, -20))
    where = tuple(round(v) for v in d.screen_of((62.5, 21.25)))
    target = app.view.to_canvas(where)
    d.click(*where)
    d.settle()
    new = [p for n, p in pins(d).items() if n not in ("left", "right")]
    assert len(new) == 1 and new[0].layer == "bar" and new[0].kind == "interior"
    np.testing.assert_allclose(new[0].at, target, atol=1e-6)
    assert app.selection == [new[0].name]
    # the marker is drawn where the pin is (pin colour: yellow)
    sx, sy = (int(round(v)) for v in d.screen_of(target))
    r, g, b = d.pixels()[sy, sx].astype(int)
    assert r > 200 and g > 180 and b < 80


def test_space_drag_pans(bar_app):
    d = bar_app
    o0 = np.array(d.app.view.origin)
    d.w.win.dispatch_event("on_key_press", key.SPACE, 0)
    d.frame()
    d.drag_path([(400, 400), (380, 420), (370, 430)])
    d.w.win.dispatch_event("on_key_release", key.SPACE, 0)
    d.frame()
    np.testing.assert_allclose(np.array(d.app.view.origin) - o0, (-30, 30))
    assert len(pins(d)) == 2  # nothing else happened


def test_click_off_every_layer_is_an_error_not_a_crash(bar_app):
    d = bar_app
    d.key(key._1)
    d.click(*d.screen_of((60, 36)))  # below the bar: transparent
    d.settle()
    assert d.app.status.level == "error" and "no layer" in d.app.status.text
    assert set(pins(d)) == {"left", "right"}
    # a pin outside the selected layer's mask: the scene refuses it, the status says why
    d.app.selected_layer = "bar"
    d.app.pin_kind = "interior"
    d.click(*d.screen_of((60, 37)))
    d.settle()
    assert d.app.status.level == "error" and "outside" in d.app.status.text
    assert set(pins(d)) == {"left", "right"}
    d.frame(3)  # the window keeps drawing


def test_drag_moves_a_pin_at_rest_and_undo_redo(bar_app):
    d = bar_app
    d.key(key._1)
    start = d.pin_screen("left")
    s = d.app.view.scale
    d.drag_path([start, (start[0] + 5 * s, start[1]), (start[0] + 10 * s, start[1] + 2 * s)])
    d.settle()
    px = 1.0 / s  # pointers move in whole window pixels: one of them in canvas units
    np.testing.assert_allclose(pins(d)["left"].at, (25, 22), atol=px)
    assert d.app.snap.dirty and d.app.title.endswith("*")
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    np.testing.assert_allclose(pins(d)["left"].at, (15, 20))
    assert not d.app.snap.dirty
    d.key(key.Z, key.MOD_CTRL | key.MOD_SHIFT)
    d.settle()
    np.testing.assert_allclose(pins(d)["left"].at, (25, 22), atol=px)
    d.key(key.Z, key.MOD_CTRL)
    d.key(key.Y, key.MOD_CTRL)
    d.settle()
    np.testing.assert_allclose(pins(d)["left"].at, (25, 22), atol=px)


def test_alt_click_and_delete_remove_pins(bar_app):
    d = bar_app
    d.key(key._1)
    d.click(*d.pin_screen("left"), mods=key.MOD_ALT)
    d.settle()
    assert set(pins(d)) == {"right"}
    d.click(*d.pin_screen("right"))
    assert d.app.selection == ["right"]
    d.key(key.DELETE)
    d.settle()
    assert pins(d) == {}
    d.key(key.Z, key.MOD_CTRL)
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert set(pins(d)) == {"left", "right"}


def test_shift_click_selects_several_and_drag_moves_them(bar_app):
    d = bar_app
    d.key(key._1)
    d.click(*d.pin_screen("left"))
    d.click(*d.pin_screen("right"), mods=key.MOD_SHIFT)
    assert d.app.selection == ["left", "right"]
    steps = len(d.scene().history.undo_stack)
    a = d.pin_screen("right")
    s = d.app.view.scale
    d.drag_path([a, (a[0] - 2 * s, a[1] + s), (a[0] - 4 * s, a[1] + 3 * s)])
    d.settle()
    p = pins(d)
    np.testing.assert_allclose(p["left"].at, (11, 23), atol=1 / s)
    np.testing.assert_allclose(p["right"].at, (101, 23), atol=1 / s)
    # both moved by exactly the same amount
    np.testing.assert_allclose(p["right"].at - p["left"].at, (90, 0), atol=1e-9)
    assert len(d.scene().history.undo_stack) == steps + 1  # one step for the whole drag


def test_arrows_nudge_and_brackets_change_depth(bar_app):
    d = bar_app
    d.key(key._1)
    d.click(*d.pin_screen("left"))
    d.key(key.RIGHT)
    d.key(key.RIGHT, key.MOD_SHIFT)
    d.key(key.DOWN)
    d.settle()
    np.testing.assert_allclose(pins(d)["left"].at, (26, 21))
    d.key(key.DOWN, key.MOD_SHIFT)  # (26, 31) is off the bar: refused, said, nothing moves
    d.settle()
    np.testing.assert_allclose(pins(d)["left"].at, (26, 21))
    assert d.app.status.level == "error"
    d.key(key.BRACKETRIGHT)
    d.key(key.BRACKETRIGHT)
    d.key(key.BRACKETLEFT)
    d.settle()
    assert pins(d)["left"].depth == 1.0


def test_h_hides_pins(bar_app):
    d = bar_app
    sx, sy = (int(round(v)) for v in d.pin_screen("left"))
    shown = d.pixels()[sy, sx].astype(int)
    d.key(key.H)
    hidden = d.pixels()[sy, sx].astype(int)
    assert not d.app.show_pins
    assert shown[1] > 150 and abs(hidden - (200, 40, 40)).max() <= 2  # yellow marker, then the bar
    d.key(key.H)
    assert (d.pixels()[sy, sx].astype(int) == shown).all()


def test_pose_drag_makes_a_pose_previews_and_is_one_step(bar_app):
    d = bar_app
    app = d.app
    assert app.mode == "pose" and app.snap.active == "rest"
    before = d.scene().to_dict()
    start = d.pin_screen("right")
    s = app.view.scale
    path = [start] + [(start[0] - k * s, start[1] - 3 * k * s) for k in range(1, 6)]
    d.press(*path[0])
    previews = 0
    for p in path[1:]:
        d.drag(*p)
        d.settle()
        previews += app.snap.preview
    assert previews >= 3  # the canvas showed previews while the pin moved
    d.release(*path[-1])
    d.settle()
    scene = d.scene()
    assert scene.active_pose != "rest" and app.snap.active == scene.active_pose and not app.snap.preview
    t = scene.data.poses[scene.active_pose]["right"]
    np.testing.assert_allclose(t.to, (100, 5), atol=1 / s)
    # the canvas shows exactly the solved pose: the bar's right end went up
    x, y = (int(round(v)) for v in d.screen_of((100, 8)))
    assert abs(d.pixels()[y, x].astype(int) - (200, 40, 40)).max() <= 3
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert scene.to_dict() == before and scene.active_pose == "rest"


def test_click_on_a_pin_at_rest_makes_no_pose(bar_app):
    d = bar_app
    d.click(*d.pin_screen("right"))
    d.settle()
    assert d.scene().active_pose == "rest" and d.app.selection == ["right"]
    assert list(d.scene().data.poses) == ["bend"]


def test_alt_drag_turns_a_pin(bar_app):
    d = bar_app
    d.app.edit(lambda s: s.set_active_pose("bend"))
    d.settle()
    c = d.pin_screen("right")
    steps = len(d.scene().history.undo_stack)
    r = 40.0
    path = [(c[0] + r * math.cos(t), c[1] - r * math.sin(t)) for t in np.linspace(0, math.pi / 2, 7)]
    d.press(*path[0], mods=key.MOD_ALT)
    for p in path[1:]:
        d.drag(*p, mods=key.MOD_ALT)
    d.release(*path[-1], mods=key.MOD_ALT)
    d.settle()
    t = d.scene().data.poses["bend"]["right"]
    assert t.angle == pytest.approx(90.0, abs=0.5)  # counter-clockwise on screen is positive
    np.testing.assert_allclose(t.to, (100, 5))  # turning does not move the target
    assert len(d.scene().history.undo_stack) == steps + 1


def test_ui_keeps_drawing_while_the_scene_thread_works(bar_app):
    import time

    d = bar_app
    d.app.edit(lambda s: time.sleep(1.2))  # a long solve
    t0 = time.perf_counter()
    frames = []
    while d.app.busy and time.perf_counter() - t0 < 10:
        t = time.perf_counter()
        d.frame()
        frames.append((t - t0, time.perf_counter() - t))
    assert max(dt for _, dt in frames) < 0.6  # no frame waited for the job
    assert len(frames) >= 3 and frames[-1][0] > 0.6  # frames went on all through it
    d.settle()


def test_dragged_marker_follows_the_pointer_while_a_solve_lags(bar_app):
    """The scene thread is held: the canvas cannot change, but the dragged pin's marker is
    drawn where the pointer is, frame after frame."""
    import threading

    d = bar_app
    gate = threading.Event()
    start = d.pin_screen("right")
    d.press(*start)
    d.drag(start[0] - 5, start[1] - 5)
    d.settle()
    d.app.edit(lambda s: gate.wait(20))  # a solve that lags
    try:
        version = d.app.snap.version
        for k in range(1, 6):
            p = (start[0] - 5 - 8 * k, start[1] - 5 + 4 * k)
            d.drag(*p)
            px = d.pixels()[int(round(p[1])), int(round(p[0]))].astype(int)
            assert px[0] > 200 and px[1] > 150 and px[2] < 90, (k, px)  # the yellow marker at the pointer
            assert d.app.snap.version == version  # no new pose was shown meanwhile
    finally:
        gate.set()
    d.release()
    d.settle()
    assert not d.app.snap.preview


def test_an_older_preview_does_not_pull_the_marker_back(bar_app):
    """A preview solved for an earlier pointer position arrives after the pointer moved
    on: the canvas shows it, the dragged marker stays at the pointer."""
    import threading

    d = bar_app
    app = d.app
    start = d.pin_screen("right")
    d.press(*start)
    d.drag(start[0] - 5, start[1] - 5)
    d.settle()
    drag = app.session._drag
    solve = drag.move_layers
    gates, entered = [threading.Event(), threading.Event()], [threading.Event(), threading.Event()]
    calls = []

    def slow(*a, **k):  # the next two preview solves wait for their gates
        k_ = len(calls)
        calls.append(k_)
        if k_ < 2:
            entered[k_].set()
            gates[k_].wait(20)
        return solve(*a, **k)
    drag.move_layers = slow
    try:
        p1, p2 = (start[0] - 25, start[1] + 10), (start[0] - 45, start[1] + 20)
        d.drag(*p1)
        assert entered[0].wait(20)  # p1's preview is being solved
        d.drag(*p2)  # the pointer moves on: p2's preview waits behind it
        v = app.snap.version
        gates[0].set()
        while app.session.latest.version == v:
            d.frame()
        d.frame(3)  # p1's preview is shown, no pointer event meanwhile
        assert app.snap.preview and app.snap.version > v
        want = app.view.to_canvas(p2)
        np.testing.assert_allclose(app.marker_xy(app.marker("right")), want, atol=1e-6)
    finally:
        for g in gates:
            g.set()
    d.release()
    d.settle()
    np.testing.assert_allclose(d.scene().to_dict()["poses"][d.scene().active_pose]["right"], want, atol=1e-6)
