"""The canvas keeps its room in a small window (issue 32: at 800x500 the canvas had 17 %
of the window): the side panels narrow to 30 % of the width and the timeline takes at most
30 % of the height until its edge is dragged; whole pixels (a fractional canvas height
drew a stray row of the picture above it)."""
from __future__ import annotations

import pytest

from tests.app.harness import Driver
from tests.conftest import ROOT

pytestmark = pytest.mark.gl

SCENE = f"{ROOT}/assets/scenes/character.json"


@pytest.mark.parametrize("size", [(960, 640), (1280, 800)])
def test_canvas_area_and_whole_pixels(size):
    d = Driver(SCENE, size=size)
    try:
        x, y, w, h = d.app.area
        W, H = d.size
        assert w >= 0.69 * W and h >= 0.55 * H
        if W >= 1100:
            assert W - w == 330 and d.w.timeline_panel.height == 200  # a big window: as before
        assert h == int(h) and w == int(w)
        px = d.pixels()[..., :3].astype(int).sum(2) / 3
        row = px[int(y), : int(w)]  # the area's top row: the panel background, not the picture
        assert (row > 200).sum() < 10
        d.w.timeline_panel.height, d.w.timeline_panel.dragged = 150.5, True  # as the grip leaves it
        d.frame(2)
        assert d.w.timeline_panel.height in (150.0, 151.0) and d.app.area[3] == int(d.app.area[3])
    finally:
        d.close()
