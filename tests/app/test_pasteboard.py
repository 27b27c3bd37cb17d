"""Content posed past the canvas edge stays on screen, dimmed on the pasteboard (as in
Spine), and its pins can still be grabbed there: drag a pin out of the canvas, look at
the window's pixels on both sides of the edge, and drag the pin back from out there."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.app.gl.canvas import PASTEBOARD as BOARD, PASTEBOARD_DIM
from tests.app.harness import Driver
from tests.conftest import bar_image, bar_scene

PASTEBOARD = np.array(BOARD) * 255  # round the canvas
RED = np.array([200, 40, 40])
pytestmark = pytest.mark.gl  # every test drives the app in a headless window (EGL)


@pytest.fixture(params=["opaque", "transparent"])
def bar_out(make_scene, request):
    """The bar posed past the edge, over an opaque colour (one pass) or a transparent
    background (the checkerboard: blended over)."""
    doc = bar_scene()
    if request.param == "transparent":
        doc["background"] = [0, 0, 0, 0]
    doc["poses"]["bend"] = {"right": [150, 20]}  # the bar's right end lies 30 px past the edge
    d = Driver(make_scene(doc, {"bar.png": bar_image()}), size=(1100, 700))
    d.app.edit(lambda s: s.set_active_pose("bend"))
    d.app.view.zoom_at(d.screen_of((60, 20)), 0.5)  # room round the canvas
    d.settle()
    yield d
    d.close()


def colour_at(d, xy) -> np.ndarray:
    x, y = (int(round(v)) for v in d.screen_of(xy))
    return d.pixels()[y - 1:y + 2, x - 1:x + 2].reshape(-1, 3).mean(axis=0)


def test_content_past_the_edge_shows_dimmed(bar_out):
    d = bar_out
    s = d.scene()
    right = [r for r in s.layers("bend") if r.name == "bar"][0]
    assert right.deformed[:, 0].max() > 140  # the pose does reach past the canvas (120 px wide)
    inside = colour_at(d, (100, 20))
    outside = colour_at(d, (135, 20))
    beyond = colour_at(d, (135, 36))  # past the edge, off the bar: bare pasteboard
    np.testing.assert_allclose(inside, RED, atol=3)
    np.testing.assert_allclose(beyond, PASTEBOARD, atol=2)
    want = PASTEBOARD * (1 - PASTEBOARD_DIM) + RED * PASTEBOARD_DIM
    np.testing.assert_allclose(outside, want, atol=4)
    # the canvas inside the edge keeps the scene's background: white, or the checkerboard
    assert colour_at(d, (110, 36)).min() >= (253 if d.scene().data.background[3] == 255 else 200)
    assert d.w.canvas.stale_errors == []  # no GL error left by the canvas's passes


def test_a_pin_past_the_edge_can_be_dragged_back(bar_out):
    d = bar_out
    x, y = d.pin_screen("right")
    assert d.app.view.to_canvas((x, y))[0] > 120  # its marker is out on the pasteboard
    d.press(x, y)
    for k in range(1, 6):
        d.drag(x - 10 * k * d.app.view.scale, y)
        d.settle()
    d.release()
    d.settle()
    got = d.scene().to_dict()["poses"]["bend"]["right"]
    xy = got["to"] if isinstance(got, dict) else got
    assert abs(xy[0] - 100) < 1.5 and abs(xy[1] - 20) < 1.5, got
    assert np.abs(colour_at(d, (135, 20)) - PASTEBOARD).max() <= 2  # nothing left out there


def test_the_posed_bounds_are_computed_once_a_snapshot(bar_out):
    """The content rect's bounds (a reduction over every vertex) are kept from frame to
    frame of one snapshot, and follow a new pose."""
    d = bar_out
    canvas = d.w.canvas
    d.frame()
    key, box = canvas._bounds
    d.frame(3)
    assert canvas._bounds[0] == key and canvas._bounds[1] is box
    assert box[1][0] == pytest.approx(150, abs=6)  # the bar's right end, posed past the edge
    d.app.edit(lambda s: s.set_active_pose("rest"))
    d.settle()
    assert canvas._bounds[0] != key and canvas._bounds[1][1][0] < box[1][0] - 20
