"""The Deform panel's chain tool (issue 35: secondary motion) in a headless window,
through the app's own controls: pins clicked into a chain (one undo step), a draft
cancelled with Esc, a chain selected, its damping slider (one undo step a drag), Remove
chain; the chain drawn; and the playback's frames swinging."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key

from puppet.app.tools import deform as deformtools
from puppet.app.ui.deform_overlay import CHAIN
from puppet.app.ui.widgets import RECTS
from tests.app.harness import Driver, widget
from tests.app.tools.test_cage_tool import colour_near
from tests.conftest import bar_image

pytestmark = pytest.mark.gl


@pytest.fixture
def d(make_scene):
    s = {"puppet": 1, "canvas": [240, 120], "background": [255, 255, 255, 255],
         "layers": [{"name": "bar", "image": "bar.png", "offset": [10, 40]}],
         "pins": [{"name": n, "layer": "bar", "at": at} for n, at in (("a", [30, 60]), ("b", [70, 60]),
                                                                       ("c", [110, 60]))],
         "animation": {"fps": 12, "keys": [{"time": 0, "pins": {"a": [30, 60]}},
                                           {"time": 0.5, "pins": {"a": [30, 20]}, "ease": "smooth"},
                                           {"time": 1.0, "pins": {"a": [30, 20]}}]}}
    drv = Driver(make_scene(s, {"bar.png": bar_image()}), size=(1100, 1000))
    yield drv
    drv.close()


def steps(d) -> int:
    return len(d.scene().history.undo_stack)


def test_pins_clicked_into_a_chain_then_tuned_and_removed(d):
    d.key(key._1)  # Pin mode
    d.settle()
    d.frame(2)
    d.click(*widget("header:Deform"))
    d.settle()
    d.click(*widget("deform-tool:chain"))
    d.frame(2)
    n0 = steps(d)
    d.click(*d.pin_screen("a"))
    d.click(*d.pin_screen("b"))
    d.frame(2)
    assert deformtools.state(d.app).chain_draft == ["a", "b"]
    d.key(key.ESCAPE)  # Esc forgets the draft, not the selection
    assert deformtools.state(d.app).chain_draft == [] and steps(d) == n0
    for name in ("a", "b", "c", "c"):  # the last pin clicked again makes the chain
        d.click(*d.pin_screen(name))
    d.settle()
    assert d.scene().to_dict()["physics"] == {"chains": [{"pins": ["a", "b", "c"], "frequency": 2.0, "damping": 0.3,
                                                          "gravity": 0.0}]}
    assert steps(d) == n0 + 1
    d.frame(2)
    mid = (np.asarray(d.pin_screen("a")) + np.asarray(d.pin_screen("b"))) / 2
    assert colour_near(d, mid, colour=CHAIN)  # drawn while the tool is on
    # the damping slider: dragged to its right end, one undo step
    x0, y0, x1, y1 = RECTS["slider:chain damping"]
    cy = (y0 + y1) / 2
    d.drag_path([(x0 + 5, cy), (x0 + 40, cy), (x1 + 30, cy)])
    d.settle()
    chain = d.scene().to_dict()["physics"]["chains"][0]
    assert chain["damping"] == pytest.approx(2.0) and steps(d) == n0 + 2
    # the frames swing: the end pin leaves the path the keys give it, the anchor does not
    L = d.scene().layers(time=0.4)[0]
    keyed = d.scene().state(time=0.4).to
    assert np.hypot(*(L.deformed[L.pins["a"]] - keyed[0])) < 0.5
    assert np.hypot(*(L.deformed[L.pins["c"]] - keyed[2])) > 3.0
    d.click(*widget("Remove chain"))
    d.settle()
    assert "physics" not in d.scene().to_dict() and steps(d) == n0 + 3
    d.app.undo()
    d.settle()
    assert d.scene().to_dict()["physics"]["chains"][0]["pins"] == ["a", "b", "c"]
