"""The timeline, record mode and onion skin, driven by synthetic events in a headless
window: keys read back from the scene, frames compared with ``scene.render(time=t)``."""
from __future__ import annotations

import copy
import os

import numpy as np
import pytest
from scipy.ndimage import binary_erosion
from pyglet.window import key

from tests.app.harness import Driver, pin_keys, widget
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl


@pytest.fixture
def bar_anim(make_scene):
    """The bar scene (keys: rest at 0 s, bend at 1 s; 10 fps) in a wider window."""
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(1100, 700))
    yield d
    d.close()


def tx(d, t):
    a = d.w.timeline_panel.area
    return a["x0"] + t * (a["x1"] - a["x0"]) / a["span"]


def row_y(d, name):
    a = d.w.timeline_panel.area
    return a["y0"] + a["ruler"] + a["rows"].index(name) * a["row"] + a["row"] / 2


def scrub(d, t):
    d.click(tx(d, t), d.w.timeline_panel.area["y0"] + 6)
    d.settle()


def times(d):
    return [k["time"] for k in d.scene().keys()]


def canvas_at_100(d):
    """The canvas as shown at 100 % zoom: (H, W, 3) int, the scene's size."""
    app = d.app
    app.show_pins = False  # the canvas alone
    d.key(key._1, key.MOD_CTRL)
    app.view.origin = tuple(float(round(v)) for v in app.view.origin)
    d.settle()
    x, y, w, h = app.view.canvas_rect(app.snap.canvas)
    return d.pixels()[int(round(y)):int(round(y)) + int(h), int(round(x)):int(round(x)) + int(w)].astype(int)


def test_scrub_shows_the_frame_at_that_time(bar_anim):
    d = bar_anim
    app, tl = d.app, d.app.timeline
    assert app.snap.time is None and not tl.showing  # opens on the active pose
    scrub(d, 0.5)
    assert tl.time == pytest.approx(0.5) and app.snap.time == pytest.approx(0.5) and app.snap.shown == "0.50 s"
    # dragging on the ruler scrubs too (snapped to frames: 10 fps)
    a = d.w.timeline_panel.area
    d.drag_path([(tx(d, 0.5), a["y0"] + 6), (tx(d, 0.6), a["y0"] + 6), (tx(d, 0.73), a["y0"] + 6)])
    d.settle()
    assert tl.time == pytest.approx(0.7) and app.snap.time == pytest.approx(0.7)
    shown = canvas_at_100(d)
    want = d.scene().render(time=0.7).astype(int)
    assert shown.shape[:2] == want.shape[:2]
    diff = np.abs(shown - want[..., :3])
    assert diff.mean() < 1.0 and np.percentile(diff, 99) <= 3, (diff.mean(), np.percentile(diff, 99))
    # and it is not the rest pose
    assert np.abs(d.scene().render(pose="rest").astype(int)[..., :3] - shown).max() > 100


def test_play_advances_and_loops(bar_anim):
    d = bar_anim
    tl = d.app.timeline
    scrub(d, 0.2)
    tl.toggle_play()
    assert tl.playing
    real0 = tl._play[0]
    tl.tick(real0 + 0.5)
    assert tl.time == pytest.approx(0.7)
    tl.tick(real0 + 1.1)  # past the last key (1 s): loops to 0.3
    assert tl.time == pytest.approx(0.3) and tl.playing  # on the frame grid (10 fps)
    tl.loop = False
    tl.tick(real0 + 5.0)
    assert tl.time == pytest.approx(1.0) and not tl.playing
    d.key(key.P)
    assert tl.playing and tl._play[1] == pytest.approx(0.0)  # at the end, Play starts over
    d.key(key.P)
    assert not tl.playing


def test_key_button_stores_the_pose_at_the_playhead(bar_anim):
    d = bar_anim
    app = d.app
    scrub(d, 0.5)
    d.click(*widget("Key"))
    d.settle()
    s = d.scene()
    assert times(d) == [0, 0.5, 1]
    k = s.keys()[1]
    assert set(k["pins"]) == {"left", "right"}
    for n, v in s.pose_at(0.5).items():
        np.testing.assert_allclose(k["pins"][n], v, atol=1e-6)
    assert app.snap.undo_label == "key at 0.5 s"
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert times(d) == [0, 1]


def test_k_keys_the_active_pose_when_the_canvas_shows_a_pose(make_scene):
    scene = bar_scene()
    del scene["animation"]
    d = Driver(make_scene(scene, {"bar.png": bar_image()}), size=(1100, 700))
    try:
        d.click(*widget("pose:bend"))
        d.settle()
        d.key(key.K)
        d.settle()
        assert d.scene().keys() == [{"time": 0.0, "pose": "bend"}]
        assert d.app.timeline.showing and d.app.snap.time == 0.0
        # a pin dragged while the canvas shows a time keys that pin there
        d.app.timeline.scrub(0.5)
        d.settle()
        p = d.pin_screen("left")
        d.drag_path([p, (p[0] + 4, p[1]), (p[0] + 12, p[1] + 6)])
        d.settle()
        keys = d.scene().keys()
        assert [k["time"] for k in keys] == [0.0, 0.5] and list(pin_keys(keys, "left")) == [0.5]
        assert not pin_keys(keys, "right")
        moved = np.subtract(pin_keys(keys, "left")[0.5], (15, 20))
        np.testing.assert_allclose(moved, np.array([12, 6]) / d.app.view.scale, atol=1e-6)
    finally:
        d.close()


def test_keys_move_copy_delete_and_ease_with_undo(bar_anim):
    d = bar_anim
    app, tl = d.app, d.app.timeline
    y = row_y(d, "poses")
    # drag the bend key from 1 s to 1.5 s
    d.drag_path([(tx(d, 1.0), y), (tx(d, 1.2), y), (tx(d, 1.5), y)])
    d.settle()
    assert times(d) == [0, 1.5] and tl.selected == [1.5]
    # Ctrl + drag copies it back to 1 s
    d.drag_path([(tx(d, 1.5), y), (tx(d, 1.3), y), (tx(d, 1.0), y)], mods=key.MOD_CTRL)
    d.settle()
    assert times(d) == [0, 1, 1.5] and d.scene().keys()[1]["pose"] == "bend"
    # select the key at 0 s, Delete removes it (the last click was in the timeline)
    d.click(tx(d, 0.0), y)
    assert tl.selected == [0.0] and tl.focus
    d.key(key.DELETE)
    d.settle()
    assert times(d) == [1, 1.5]
    assert len(d.scene().data.pins) == 2  # pins untouched
    # ease of the selected key: smooth, then bezier with its curve
    d.click(tx(d, 1.5), y)
    tl.set_ease("smooth")
    d.settle()
    assert d.scene().keys()[1]["ease"] == "smooth"
    tl.set_ease("bezier", [0.1, 0.2, 0.3, 0.9])
    d.settle()
    assert d.scene().keys()[1]["curve"] == [0.1, 0.2, 0.3, 0.9]
    # copy / paste at the playhead
    d.key(key.C, key.MOD_CTRL)
    scrub(d, 0.3)
    tl.focus = True
    d.key(key.V, key.MOD_CTRL)
    d.settle()
    assert times(d) == [0.3, 1, 1.5] and d.scene().keys()[0]["ease"] == "bezier"
    # undo walks back every step
    for want in ([1, 1.5], [1, 1.5], [1, 1.5], [0, 1, 1.5], [0, 1.5], [0, 1]):
        d.key(key.Z, key.MOD_CTRL)
        d.settle()
        assert times(d) == want, app.snap.undo_label
    assert d.scene().keys() == bar_scene()["animation"]["keys"]


def test_record_mode_keys_replay_the_dragged_path(bar_anim):
    d = bar_anim
    app, tl = d.app, d.app.timeline
    before = copy.deepcopy(d.scene().keys())
    d.click(*widget("Record"))
    assert tl.record
    tl.tolerance = 1.0
    tl.clock = clock = Clock()
    scrub(d, 0.2)
    p = d.pin_screen("left")
    # a curved path: the pin goes right and up, then down again, 40 moves 1/20 s apart;
    # it rests 0.3 s in the middle (sampled where it rests)
    p = (round(p[0]), round(p[1]))  # the pointer is on whole pixels
    path = [p] + [(p[0] + 4 * k, p[1] - round(25 * np.sin(k / 10))) for k in range(1, 40)]
    d.press(*path[0])
    for k, q in enumerate(path[1:]):
        clock.now += 0.05 if k != 20 else 0.3
        if k == 20:
            tl.tick()
        d.drag(*q)
    d.release(*path[-1])
    d.settle()
    rec = tl.last_recording
    assert rec is not None and rec.start == pytest.approx(0.2) and len(rec.times) >= 40
    assert rec.times[-1] == pytest.approx(0.2 + 38 * 0.05 + 0.3)  # real time at 1x
    s = d.scene()
    i = [pin.name for pin in s.data.pins].index("left")
    keyed = list(pin_keys(s.keys(), "left"))
    assert 2 <= len(keyed) < len(rec.times) / 2  # simplified
    assert keyed[0] == pytest.approx(0.2, abs=1e-3)
    # replay: the pin's target at each sample time is within the tolerance of the sample
    # (+ the 0.01 px the keys are rounded to)
    err = [np.hypot(*(s.state(time=t).to[i] - xy)) for t, xy in zip(rec.times, rec.points["left"])]
    assert max(err) <= tl.tolerance + 0.02, max(err)
    # the samples really are the dragged path (canvas units)
    np.testing.assert_allclose(rec.points["left"][-1], np.subtract(path[-1], p) / app.view.scale + (15, 20),
                               atol=1e-6)
    # the playhead is back where the recording began, showing the recorded frame there
    assert tl.time == pytest.approx(0.2) and app.snap.time == pytest.approx(0.2)
    # one undo step
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert d.scene().keys() == before


def test_record_speed_half_time(bar_anim):
    """At 0.5x the playhead runs at half speed: 2 s of dragging make 1 s of keys."""
    d = bar_anim
    tl = d.app.timeline
    tl.record, tl.speed, tl.clock = True, 0.5, Clock()
    scrub(d, 0.0)
    p = d.pin_screen("right")
    p = (round(p[0]), round(p[1]))
    d.press(*p)
    for k in range(1, 21):
        tl.clock.now += 0.1
        d.drag(p[0] - 3 * k, p[1] + k)  # straight at constant speed: two keys
    d.release()
    d.settle()
    keyed = pin_keys(d.scene().keys(), "right")
    assert list(keyed) == [0.0, 1.0]
    np.testing.assert_allclose(keyed[1.0], np.array(keyed[0.0])
                               + np.array([-60, 20]) / d.app.view.scale, atol=0.01)


def test_selected_pins_record_together(bar_anim):
    d = bar_anim
    tl = d.app.timeline
    tl.record, tl.clock = True, Clock()
    scrub(d, 0.0)
    left, right = d.pin_screen("left"), d.pin_screen("right")
    d.click(*left)  # a click without a drag records nothing and selects the pin
    d.settle()
    d.click(*right, mods=key.MOD_SHIFT)
    d.settle()
    assert d.app.selection == ["left", "right"]
    before = d.scene().keys()
    assert before == bar_scene()["animation"]["keys"]
    d.press(*left)
    for k in range(1, 11):
        tl.clock.now += 0.1
        d.drag(left[0], left[1] + 2 * k)
    d.release()
    d.settle()
    keys = d.scene().keys()
    for pin in ("left", "right"):
        assert list(pin_keys(keys, pin)) == [0.0, 1.0]
    s = d.scene()
    at1 = s.state(time=1.0).to
    np.testing.assert_allclose(at1[0] - s.state(time=0.0).to[0], [0, 20 / d.app.view.scale], atol=0.02)


class Clock:
    """A clock the test moves."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def _mask(rgba):
    """Where the red bar is in a render over white."""
    return (rgba[..., 0] > 150) & (rgba[..., 1] < 120)


def test_onion_skin_draws_tinted_ghosts(bar_anim):
    d = bar_anim
    app, tl = d.app, d.app.timeline
    s = d.scene()
    rest, bend = _mask(s.render(time=0.0)), _mask(s.render(time=1.0))
    scrub(d, 1.0)
    shown = canvas_at_100(d)
    only_rest = binary_erosion(rest & ~bend, iterations=2)  # away from the edges
    ys, xs = np.nonzero(only_rest)
    assert len(ys) > 50
    assert np.all(shown[ys, xs] >= 250)  # white: no ghost yet
    d.click(*widget("onion"))
    d.settle()
    assert tl.onion_on and [g[0] for g in app.snap.ghosts] == ["before"]
    on = canvas_at_100(d)
    ghost = on[ys, xs]
    assert np.median(ghost[:, 0] - ghost[:, 1]) > 40  # tinted red (the key before)
    inner = binary_erosion(bend, iterations=2)
    assert np.all(on[inner] == shown[inner])  # the current frame unchanged, in front
    # at 0 s the ghost is the key after, tinted green
    scrub(d, 0.0)
    on0 = canvas_at_100(d)
    only_bend = binary_erosion(bend & ~rest, iterations=2)
    ys, xs = np.nonzero(only_bend)
    assert len(ys) > 20
    g = on0[ys, xs]
    assert np.median(g[:, 1] - g[:, 0]) > 25
    # frames mode: ghosts 1/fps either side
    tl.onion["mode"], tl.onion["count"] = "frames", 2
    scrub(d, 0.5)
    assert sorted((side, round(w, 2)) for side, w, _ in app.snap.ghosts) == [
        ("after", 0.5), ("after", 1.0), ("before", 0.5), ("before", 1.0)]


def test_export_dialog_writes_the_animation(bar_anim, tmp_path):
    d = bar_anim
    app = d.app
    d.key(key.E, key.MOD_CTRL)
    assert app.dialog == "export"
    form = app.export_form
    assert form.fps == 10 and form.end == 1.0
    form.path = str(tmp_path / "frames") + os.sep
    d.frame(2)
    d.click(*widget("Export"))
    assert form.run.wait(120), form.run.state
    assert form.run.state == "done", form.run.message
    files = sorted(os.listdir(tmp_path / "frames"))
    assert len(files) == 11 and form.run.done == form.run.total == 11
    # a bad output is one line in the dialog, nothing written
    form.path = str(tmp_path / "out.xyz")
    d.frame(2)
    d.click(*widget("Export"))
    assert form.run.wait(120)
    assert form.run.state == "failed" and "out.xyz" in form.run.message
    assert not (tmp_path / "out.xyz").exists()
    d.frame(2)
    d.click(*widget("Close"))
    assert app.dialog is None
