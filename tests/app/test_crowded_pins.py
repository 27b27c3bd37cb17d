"""Pins stay usable when a big character is fitted into a small window (issue 32: at a
small window the canvas shrank to 17 % and 41 pins covered the character): markers shrink
where the view crowds them, the art shows between them, and a click still picks the pin
under it."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key

from puppet.app.gl.window import MIN_SIZE
from puppet.app.model import pick
from tests.app.harness import Driver
from tests.conftest import bar_image

pytestmark = pytest.mark.gl

#: a tall character (1200 px) with 45 pins 50 px apart
W, H, STEP = 400, 1200, 50.0


def crowded_scene() -> dict:
    pins = [{"name": f"p{i}_{j}", "layer": "body", "at": [150.0 + STEP * i, 350.0 + STEP * j]}
            for i in range(3) for j in range(15)]
    return {"puppet": 1, "canvas": [W, H], "background": [255, 255, 255, 255],
            "layers": [{"name": "body", "image": "body.png"}], "pins": pins}


def test_spacing_and_scale_by_hand():
    assert pick.spacing(np.array([[0, 0], [3, 4], [100, 0]])) == 5.0  # nearest: 5, 5, 95
    assert pick.spacing(np.zeros((1, 2))) == np.inf
    assert pick.marker_scale(50.0, 1.0) == 1.0  # 50 window px apart: full size
    assert pick.marker_scale(50.0, 0.22) == pytest.approx(0.5)  # 11 px apart: half size
    assert pick.marker_scale(50.0, 0.01) == pick.MIN_MARKER_SCALE


def test_crowded_pins_shrink_show_the_art_and_still_pick(make_scene):
    d = Driver(make_scene(crowded_scene(), {"body.png": bar_image(W, H, (100, 300, 300, 1100), (40, 90, 200))}),
               size=MIN_SIZE)
    try:
        d.key(key._1)  # Pin mode: a click on a pin selects it
        d.settle()
        app = d.app
        s = app.marker_scale()
        assert s == pytest.approx(pick.marker_scale(STEP, app.view.scale)) and s < 0.7, (s, app.view.scale)
        # the art between the pins: pixels the markers change, over the character's box
        x0, y0 = map(int, d.screen_of((100.0, 300.0)))
        x1, y1 = map(int, d.screen_of((300.0, 1100.0)))
        shown = d.pixels()[y0:y1, x0:x1].astype(int)
        d.key(key.H)
        hidden = d.pixels()[y0:y1, x0:x1].astype(int)
        d.key(key.H)
        covered = float((np.abs(shown - hidden).max(axis=2) > 24).mean())
        assert covered < 0.4, covered  # 0.29 measured; full-size markers covered 0.71 of it
        for name in ("p0_0", "p1_7", "p2_14"):
            d.click(*d.pin_screen(name))
            d.settle()
            assert app.selection == [name] or set(app.selection) == {name}, (name, app.selection)
    finally:
        d.close()
