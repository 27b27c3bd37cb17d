"""Pose keys with pin ``overrides`` in the timeline (marks in the pins' rows, copy and paste
keep them), and labels that follow the state: the toolbar while recording, the status
line when an export ends (issue 23)."""
from __future__ import annotations

import os

import pytest
from pyglet.window import key

from puppet.app.ui import menus
from tests.app.harness import Driver, widget
from tests.app.test_timeline import Clock, row_y, scrub, tx
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl


@pytest.fixture
def overridden(make_scene):
    scene = bar_scene()
    scene["animation"]["keys"][1]["overrides"] = {"left": [20, 28]}
    d = Driver(make_scene(scene, {"bar.png": bar_image()}), size=(1100, 700))
    yield d
    d.close()


def test_override_marks_in_pin_rows_and_copy_paste_keeps_them(overridden):
    d = overridden
    tl = d.app.timeline
    assert d.w.timeline_panel.area["rows"] == ["poses", "left"]
    d.click(tx(d, 1.0), row_y(d, "left"))  # the override's mark in the pin's row
    d.settle()
    assert tl.selected == [1.0]
    d.key(key.C, key.MOD_CTRL)
    scrub(d, 0.5)
    d.key(key.V, key.MOD_CTRL)
    d.settle()
    pasted = next(k for k in d.scene().keys() if k["time"] == pytest.approx(0.5))
    assert pasted["pose"] == "bend" and pasted["overrides"] == {"left": [20.0, 28.0]}


def test_toolbar_follows_the_playhead_while_recording(overridden):
    d = overridden
    app, tl = d.app, d.app.timeline
    d.click(*widget("Record"))
    tl.clock = clock = Clock()
    scrub(d, 0.2)
    assert menus.shown_label(app) == "pose: 0.20 s"
    x, y = (round(v) for v in d.pin_screen("right"))
    d.press(x, y)
    for k in range(1, 12):
        clock.now += 0.1
        d.drag(x, y + 2 * k)
    assert tl.recording is not None and tl.time == pytest.approx(1.3, abs=0.01)
    assert menus.shown_label(app) == "recording: 1.30 s"
    d.release(x, y + 22)
    d.settle()
    assert menus.shown_label(app) == "pose: 0.20 s"  # back where the recording began


def test_status_line_tells_when_the_export_ends(overridden, tmp_path):
    d = overridden
    app = d.app
    d.key(key.E, key.MOD_CTRL)
    form = app.export_form
    form.path = str(tmp_path / "frames") + os.sep
    d.frame(2)
    d.click(*widget("Export"))
    assert app.status.text.startswith("exporting")
    assert form.run.wait(120) and form.run.state == "done", form.run.message
    d.frame(2)
    assert app.status.text.startswith("exported 11 frames"), app.status.text
    assert app.dialog == "export"  # the dialog stays open with its message
