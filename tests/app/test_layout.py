"""The window at its minimum size (issue 23): every toolbar control is on screen, inside
the toolbar, and does its job when clicked; the toolbar wraps rather than cutting off."""
from __future__ import annotations

import pytest

from puppet.app.gl.window import MIN_SIZE
from tests.app.harness import Driver, widget
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl

STEPS = ["step:image", "step:layers", "step:link", "step:pins", "step:deform", "step:pose"]
TOGGLES = {"pins": "show_pins", "mesh": "show_mesh", "depth": "depth_view", "links": "show_links"}


@pytest.fixture
def small(make_scene):
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=MIN_SIZE)
    yield d
    d.close()


def test_minimum_size_is_set_and_smaller_sizes_are_raised_to_it(make_scene):
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(640, 400))
    try:
        assert d.w.win.get_size() == MIN_SIZE
        # (the headless window keeps no minimum: the X window's WM_NORMAL_HINTS carry it, see test_xvfb)
    finally:
        d.close()


def test_every_toolbar_control_works_at_the_minimum_size(small):
    from puppet.app.ui.widgets import RECTS

    d = small
    app = d.app
    W, H = MIN_SIZE
    labels = STEPS + ["Pin mode", "Pose mode"] + list(TOGGLES) + ["Fit", "Undo", "Redo", "?"]
    bottom = app.area[1]  # the toolbar ends where the canvas begins
    for label in labels:
        x0, y0, x1, y1 = RECTS[label]
        assert 0 <= x0 and x1 <= W and y1 <= bottom, (label, RECTS[label])
    assert max(RECTS[a][3] for a in labels) > min(RECTS[a][1] for a in labels) + 20  # two rows
    for step in STEPS:
        d.click(*widget(step))
        d.settle()
        assert app.script.step == step.split(":")[1]
    d.click(*widget("Pin mode"))
    assert app.mode == "pin"
    d.click(*widget("Pose mode"))
    assert app.mode == "pose"
    for label, attr in TOGGLES.items():
        was = getattr(app, attr)
        d.click(*widget(label))
        assert getattr(app, attr) != was, label
        d.click(*widget(label))
    app.view.zoom_at((100, 300), 3.0)
    scale = app.view.scale
    d.click(*widget("Fit"))
    assert app.view.scale == pytest.approx(scale / 3.0)
    app.edit(lambda s: s.add_pose("p2"))
    d.settle()
    d.click(*widget("Undo"))
    d.settle()
    assert "p2" not in d.scene().data.poses
    d.click(*widget("Redo"))
    d.settle()
    assert "p2" in d.scene().data.poses
    d.click(*widget("?"))
    assert app.show_help


def test_a_wide_window_keeps_one_row(make_scene):
    from puppet.app.ui.widgets import RECTS

    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(1400, 800))
    try:
        ys = {RECTS[k][1] for k in ("step:image", "pins", "?")}
        assert max(ys) - min(ys) < 2
    finally:
        d.close()


def test_file_open_lands_in_the_mode_the_command_line_opens(tmp_path, make_scene):
    from tests.conftest import write_rgba

    scene = make_scene(bar_scene(), {"bar.png": bar_image()})
    picture = write_rgba(tmp_path / "pic.png", bar_image())
    d = Driver(picture, size=MIN_SIZE)
    try:
        assert d.app.mode == "pin" and d.app.script.step == "image"
        d.app.open(scene)  # File > Open
        d.settle()
        assert d.app.mode == "pose" and d.app.script.step == "pose" and d.app.snap.shown == "rest"
    finally:
        d.close()
    d = Driver(scene, size=MIN_SIZE)  # the command line
    try:
        assert d.app.mode == "pose" and d.app.script.step == "pose" and d.app.snap.shown == "rest"
    finally:
        d.close()


def test_pins_are_ringed_dark_and_light(small):
    d = small
    x, y = (int(round(v)) for v in d.pin_screen("left"))
    px = d.pixels().astype(int)
    ring = [px[y, x + k] for k in range(4, 11)]  # out from the dot: yellow, dark outline, light ring
    assert min(p.sum() for p in ring) < 200 and max(p.sum() for p in ring[2:]) > 600


def test_timeline_top_edge_drags_its_height(small):
    from puppet.app.ui.timeline_panel import MIN_HEIGHT

    d = small
    app, panel = d.app, d.w.timeline_panel
    h0, area0 = panel.height, app.area
    x, y = widget("timeline:grip")
    d.drag_path([(x, y), (x, y - 40), (x, y - 100)])
    d.frame(2)
    assert panel.height == pytest.approx(h0 + 100)
    assert app.area[3] == pytest.approx(area0[3] - 100)  # the canvas gave the room
    x, y = widget("timeline:grip")
    d.drag_path([(x, y), (x, y - 300), (x, 5)])  # up to the top: the canvas keeps 120 px
    d.frame(2)
    assert app.area[3] == pytest.approx(120, abs=1)
    x, y = widget("timeline:grip")
    d.drag_path([(x, y), (x, y + 300), (x, MIN_SIZE[1] - 2)])  # down: no smaller than its controls
    d.frame(2)
    assert panel.height == MIN_HEIGHT
    assert widget("timeline")[1] < MIN_SIZE[1]  # the tracks still show


def test_a_file_dropped_on_the_window_opens(small, tmp_path):
    from tests.conftest import write_rgba

    d = small
    app = d.app
    picture = write_rgba(tmp_path / "drop.png", bar_image())
    d.w.win.dispatch_event("on_file_drop", 100, 100, [str(tmp_path / "notes.txt")])
    d.frame()
    assert app.status.level == "error" and "notes.txt" in app.status.text
    d.w.win.dispatch_event("on_file_drop", 100, 100, [picture])
    d.settle()
    assert app.snap.file == str(tmp_path / "drop.json") and app.mode == "pin" and app.script.step == "image"
    app.edit(lambda s: s.add_pose("p"))  # unsaved: a drop asks first
    d.settle()
    d.w.win.dispatch_event("on_file_drop", 100, 100, [str(tmp_path / "scene.json")])
    d.frame()
    assert app.dialog == "unsaved"
