"""Layer via Cut / Copy in the app (issue 23): the Layers step's lasso on a flat picture
of a disc with a bar stuck on it (tests/scene/document/test_split.py's picture) cuts the bar into
a new layer in one undo step; swung away, the canvas shows background where the bar
stuck out and the refilled disc inside; Layer via Copy keeps the bar behind."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key

from tests.app.harness import Driver, widget
from tests.conftest import write_rgba
from tests.scene.document.test_split import AROUND_BAR, BAR, DISC, near, picture, shapes

pytestmark = pytest.mark.gl


@pytest.fixture
def disc_app(tmp_path):
    d = Driver(write_rgba(tmp_path / "disc.png", picture()), size=(960, 640))
    yield d
    d.close()


def click_widget(d, label):
    d.click(*widget(label))
    d.settle()


def lasso_and_swing(d, op: str | None):
    """Layers step, lasso around the bar (``op``: the selection's choice, None = default),
    then a pin on the bar dragged 65 px down in Pose; returns the window's canvas at
    100 % (H, W, 3) and the scene's render of the pose."""
    app = d.app
    click_widget(d, "step:layers")
    assert app.script.tool == "lasso" and app.selected_layer == "layer1"
    if op is not None:
        click_widget(d, f"select:{op}")
    undo_depth = len(d.scene().history.undo_stack)
    d.drag_path([d.screen_of(p) for p in AROUND_BAR + [AROUND_BAR[0]]])
    d.settle()
    assert app.status.level == "info", app.status.text
    assert [L.name for L in d.scene().data.layers] == ["layer1", "layer2"]
    assert len(d.scene().history.undo_stack) == undo_depth + 1  # one undo step
    d.frame(2)
    assert app.selected_layer == "layer2"  # the new layer is selected
    click_widget(d, "step:pins")
    d.click(*d.screen_of((150, 80)))
    d.settle()
    pin = d.scene().data.pins[-1]
    assert pin.layer == "layer2"
    click_widget(d, "step:pose")
    p = d.screen_of((150, 80))
    s = app.view.scale
    d.drag_path([p, (p[0], p[1] + 5), (p[0], p[1] + 65 * s)])
    d.settle()
    pose = d.scene().active_pose
    assert pose != "rest", app.status.text
    assert d.scene().data.poses[pose][pin.name].to[1] == pytest.approx(145, abs=1.0)
    app.show_pins = False
    d.key(key._1, key.MOD_CTRL)  # 100 %
    app.view.origin = tuple(float(round(v)) for v in app.view.origin)
    d.settle()
    x, y, w, h = (int(round(v)) for v in app.view.canvas_rect(app.snap.canvas))
    window = d.pixels()[y:y + h, x:x + w]
    return window, d.scene().render(pose=pose)


def test_lasso_cut_removes_the_part_from_the_layer_behind(disc_app):
    d = disc_app
    disc, bar = shapes()
    window, img = lasso_and_swing(d, None)  # Layer via Cut is the default
    out = bar & ~disc
    assert (img[..., 3] > 0)[out].mean() <= 0.02  # the new scene's background is transparent
    assert not near(img, BAR, 60)[disc].any()
    assert near(img, BAR, 30)[np.roll(bar, 65, axis=0)].mean() > 0.9
    # the window shows the same (the canvas at 100 %)
    assert window.shape[:2] == img.shape[:2]
    checker = ~near(window, BAR, 60) & ~near(window, DISC, 60) & (window.min(axis=-1) > 150)
    assert checker[out].mean() >= 0.98  # the checkerboard behind transparency
    assert not near(window, BAR, 60)[disc].any()
    assert near(window, DISC, 60)[disc & bar].mean() > 0.95  # refilled
    # one Ctrl+Z takes the pose, the pin, then the cut back
    for _ in range(3):
        d.key(key.Z, key.MOD_CTRL)
        d.settle()
    assert [L.name for L in d.scene().data.layers] == ["layer1"]
    assert d.scene().built.images[0].mask[bar].all()


def test_lasso_copy_keeps_the_part_behind(disc_app):
    d = disc_app
    disc, bar = shapes()
    window, img = lasso_and_swing(d, "copy")
    assert near(img, BAR, 30)[bar & ~disc].mean() > 0.95
    assert near(window, BAR, 30)[bar & ~disc].mean() > 0.95
