"""The History panel: the undo stack listed under the opened state, a click jumps back or
forward to that state (issue 23)."""
from __future__ import annotations

import pytest

from puppet.app.ui import history_panel
from tests.app.harness import Driver, widget
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl


@pytest.fixture
def bar_app(make_scene):
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(960, 900))
    yield d
    d.close()


def poses(d):
    return sorted(d.scene().data.poses)


def test_history_lists_the_steps_and_jumps(bar_app):
    d = bar_app
    app = d.app
    for name in ("p1", "p2", "p3"):
        app.edit(lambda s, name=name: s.add_pose(name))
        d.settle()
    labels = [r[0] for r in history_panel.rows(app.snap)]
    assert labels[0] == "(opened)" and len(labels) == 4 and all("p" in x for x in labels[1:])
    d.click(*widget("header:History"))
    d.frame(2)
    d.click(*widget("history:1"))  # after the first step
    d.settle()
    assert poses(d) == ["bend", "p1"]
    assert [r[1:] for r in history_panel.rows(app.snap)] == [(-1, False), (0, False), (1, True), (2, True)]
    d.frame(2)
    d.move(300, 620)  # no tooltip in the picture
    d.shot("history")  # docs/app/history.png
    d.click(*widget("history:3"))  # forward again, to the last
    d.settle()
    assert poses(d) == ["bend", "p1", "p2", "p3"]
    d.frame(2)
    d.click(*widget("history:0"))  # the file as opened
    d.settle()
    assert poses(d) == ["bend"] and not app.snap.dirty
    assert "undid 3 steps" in app.status.text
