"""Every kind of pin drag in the headless window (one pin, three pins, a key drag on the
timeline, a recording) previews while it moves and releases exactly what ``render``
gives: the shown layers are the scene's own solve, bit for bit, and the canvas matches
``scene.render`` within a few grey levels."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key

from tests.app.harness import Driver
from tests.app.model.test_session import at_time
from tests.app.test_timeline import Clock, canvas_at_100
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl  # every test drives the app in a headless window (EGL)


@pytest.fixture
def three_pins(make_scene):
    doc = bar_scene()
    doc["pins"].insert(1, {"name": "mid", "layer": "bar", "at": [60, 20]})
    d = Driver(make_scene(doc, {"bar.png": bar_image()}), size=(1100, 700))
    yield d
    d.close()


def same(a, b) -> bool:
    return len(a) == len(b) and all(np.array_equal(x.deformed, y.deformed) and np.array_equal(x.depth, y.depth)
                                    for x, y in zip(a, b))


def drag(d, names, dx, dy, steps=6, clock=None):
    """Select ``names`` (Shift-click), drag the last by (dx, dy) window pixels; True when
    the canvas showed a preview on the way."""
    for n in names[:-1]:
        d.click(*d.pin_screen(n), mods=key.MOD_SHIFT if n != names[0] else 0)
    start = d.pin_screen(names[-1])
    d.press(*start, mods=key.MOD_SHIFT if len(names) > 1 else 0)
    previews = 0
    for k in range(1, steps + 1):
        if clock is not None:
            clock.now += 0.05
        d.drag(start[0] + dx * k / steps, start[1] + dy * k / steps)
        d.settle()
        previews += d.app.snap.preview
    d.release()
    d.settle()
    return previews > 0


def matches_render(d, want) -> None:
    shown = canvas_at_100(d)
    diff = np.abs(shown - want.astype(int)[..., :3])
    assert diff.mean() < 1.0 and np.percentile(diff, 99) <= 3, (diff.mean(), np.percentile(diff, 99))


@pytest.mark.parametrize("names", [["right"], ["left", "mid", "right"]])
def test_pose_drag_releases_the_exact_pose(three_pins, names):
    d = three_pins
    d.app.edit(lambda s: s.set_active_pose("bend"))
    d.settle()
    undo = len(d.scene().history.undo_stack)
    assert drag(d, names, 0, -12 * d.app.view.scale)
    s, snap = d.scene(), d.app.snap
    assert not snap.preview and d.app.selection == names
    pose = s.to_dict()["poses"]["bend"]
    assert same(snap.layers, s.layers(pose)) and same(snap.layers, s.layers("bend"))
    assert len(s.history.undo_stack) == undo + 1
    matches_render(d, s.render(pose="bend"))


def test_key_drag_releases_the_frame_at_that_time(three_pins):
    d = three_pins
    d.app.timeline.scrub(0.5)
    d.settle()
    assert d.app.snap.time == 0.5
    before = {n: d.app.marker_xy(d.app.marker(n)) for n in ("mid", "right")}  # where the frame shows them
    assert drag(d, ["mid", "right"], 0, 10 * d.app.view.scale)
    s, snap = d.scene(), d.app.snap
    assert not snap.preview and snap.time == 0.5
    assert 0.5 in [k["time"] for k in s.keys()]
    for n in ("mid", "right"):  # keyed 10 canvas px below where they were shown
        np.testing.assert_allclose(at_time(s, 0.5, n), np.add(before[n], (0, 10)), atol=0.5 / d.app.view.scale)
    assert same(snap.layers, s.layers(time=0.5))
    matches_render(d, s.render(time=0.5))


def test_recording_releases_the_frame_where_it_began(three_pins):
    d = three_pins
    tl = d.app.timeline
    tl.record, tl.tolerance = True, 0.5
    tl.clock = clock = Clock()
    tl.scrub(0.2)
    d.settle()
    assert drag(d, ["right"], 0, 15 * d.app.view.scale, steps=8, clock=clock)
    s, snap = d.scene(), d.app.snap
    assert tl.time == pytest.approx(0.2) and snap.time == pytest.approx(0.2) and not snap.preview
    assert len(s.keys()) > 2  # the recording made keys
    assert same(snap.layers, s.layers(time=0.2))
    matches_render(d, s.render(time=0.2))
