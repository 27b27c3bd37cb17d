"""Panels (layers, poses, pins, reference picture) and the canvas views, clicked through
ImGui in a headless window."""
from __future__ import annotations

import os
import re

import numpy as np
import pytest
from pyglet.window import key

from tests.app.harness import widget
from tests.conftest import ROOT, write_rgba

pytestmark = pytest.mark.gl


def px(d, xy):
    x, y = (int(round(v)) for v in d.screen_of(xy))
    return d.pixels()[y, x].astype(int)


def test_layer_visibility_select_and_reorder(two_bars):
    d = two_bars
    app = d.app
    d.key(key.H)  # no pin markers in the way
    overlap = (60, 27)  # red (back) and blue (front) both cover it
    assert abs(px(d, overlap) - (40, 40, 200)).max() <= 2
    steps = len(d.scene().history.undo_stack)
    d.click(*widget("visible:blue"))
    d.settle()
    assert app.hidden == {"blue"}
    assert abs(px(d, overlap) - (200, 40, 40)).max() <= 2
    # a scene edit (issue 32: it was the app's alone, not saved): one undo step, in the file, not rendered
    assert len(d.scene().history.undo_stack) == steps + 1
    assert d.scene().to_dict()["layers"][1]["visible"] is False
    out = d.scene().render()
    x, y = overlap
    assert abs(out[y, x, :3].astype(int) - (200, 40, 40)).max() <= 2
    d.click(*widget("visible:blue"))
    d.settle()
    assert "visible" not in d.scene().to_dict()["layers"][1] and not app.hidden
    d.click(*widget("layer:red"))
    assert app.selected_layer == "red"
    # drag the red layer's row onto the blue one: red goes to blue's place, in front
    a, b = widget("layer:red"), widget("layer:blue")
    d.drag_path([a, (a[0], a[1] - 10), (b[0], b[1] - 5), b])
    d.settle()
    assert [L.name for L in d.scene().data.layers] == ["blue", "red"]
    assert abs(px(d, overlap) - (200, 40, 40)).max() <= 2
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert [L.name for L in d.scene().data.layers] == ["red", "blue"]


def test_mesh_slider_remeshes_only_that_layer_live_in_one_step(two_bars):
    d = two_bars
    d.click(*widget("layer:red"))
    d.settle()
    scene = d.scene()
    blue_mesh = scene.built.meshes[1]
    red_tris = len(scene.built.meshes[0].F)
    steps = len(scene.history.undo_stack)
    from puppet.app.ui.widgets import RECTS

    x0, y0, x1, y1 = RECTS["slider:triangle size"]  # the label is right of the slider's frame
    y = (y0 + y1) / 2
    d.press(x0 + 0.7 * (x1 - x0), y)
    for x in np.linspace(x0 + 0.6 * (x1 - x0), x0 + 4, 5):
        d.drag(x, y)
        d.settle()
    d.release()
    d.settle()
    scene = d.scene()
    area = scene.data.layers[0].mesh.max_area
    assert area is not None and area < 5
    assert len(scene.built.meshes[0].F) > red_tris  # denser
    assert scene.built.meshes[1] is blue_mesh  # the other layer was not re-meshed
    assert len(scene.history.undo_stack) == steps + 1
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert d.scene().data.layers[0].mesh.max_area is None


def test_inpaint_and_mesh_views(two_bars):
    d = two_bars
    d.key(key.H)
    plain = d.pixels()
    d.key(key.M)
    wire = d.pixels()
    changed = np.any(wire != plain, axis=2)
    assert changed.sum() > 500  # mesh edges drawn over the bars
    assert d.app.show_mesh
    d.key(key.M)
    d.key(key.D)  # depth view: back layer blue-ish, front layer red-ish
    back, front = px(d, (20, 20)), px(d, (130, 35))
    assert back[2] > back[0] and front[0] > front[2]
    d.key(key.D)
    d.key(key.L)
    assert d.app.show_links


def test_poses_panel(bar_app):
    d = bar_app
    app = d.app
    d.click(*widget("pose:bend"))
    d.settle()
    assert app.snap.active == "bend" and app.mode == "pose"
    d.click(*widget("Duplicate"))
    d.settle()
    assert app.snap.active == "bend copy"
    assert d.scene().to_dict()["poses"]["bend copy"] == d.scene().to_dict()["poses"]["bend"]
    d.click(*widget("field:pose name"))
    d.type("reach")
    d.key(key.ENTER)
    d.settle()
    assert app.snap.active == "reach" and "bend copy" not in app.snap.poses
    d.click(*widget("Delete"))
    d.settle()
    assert app.snap.active == "rest" and "reach" not in app.snap.poses
    d.click(*widget("New"))
    d.settle()
    assert app.snap.active == "pose" and d.scene().data.poses["pose"] == {}
    # rest is read-only: no rename, no delete
    d.click(*widget("pose:rest"))
    d.settle()
    n = len(app.snap.poses)
    d.click(*widget("Delete"))
    d.settle()
    assert len(app.snap.poses) == n and app.snap.active == "rest"


def test_switching_to_a_solved_pose_is_instant(bar_app):
    d = bar_app
    for name in ("bend", "rest", "bend"):
        d.click(*widget(f"pose:{name}"))
        d.settle()
    memo = d.scene().rig.memo
    solves = memo.count("solve")
    for name in ("rest", "bend", "rest"):
        d.click(*widget(f"pose:{name}"))
        d.settle()
    assert memo.count("solve") == solves  # nothing solved again


def test_exterior_pins_have_their_own_kind_and_colour(bar_app):
    d = bar_app
    d.key(key._1)
    d.click(*widget("radio:exterior"))
    assert d.app.pin_kind == "exterior"
    where = tuple(round(v) for v in d.screen_of((60, 12)))
    d.click(*where)
    d.settle()
    new = [p for p in d.scene().data.pins if p.name not in ("left", "right")]
    assert len(new) == 1 and new[0].kind == "exterior" and new[0].name.startswith("epin")
    r, g, b = d.pixels()[where[1], where[0]].astype(int)
    assert b > 200 and r < 120  # blue diamond, not a yellow dot


def test_pin_names_show_on_hover(bar_app):
    d = bar_app
    far = d.pixels()
    d.move(*d.pin_screen("left"))
    d.frame(2)
    near = d.pixels()
    x, y = (int(v) for v in d.pin_screen("left"))
    label = near[y - 30:y, x + 8:x + 120]
    assert (np.abs(label.astype(int) - far[y - 30:y, x + 8:x + 120]).sum(axis=2) > 60).sum() > 50


def test_reference_picture(bar_app, tmp_path):
    d = bar_app
    ref = np.zeros((40, 120, 4), np.uint8)
    ref[..., 2] = 255
    ref[..., 3] = 255
    path = write_rgba(tmp_path / "ref.png", ref)
    d.app.edit(lambda s: s.set_underlay(path, opacity=0.5))
    d.settle()
    d.key(key.H)
    # under the (transparent part of the) canvas: blue at half opacity over white
    r, g, b = px(d, (60, 36))
    assert abs(b - 255) <= 2 and abs(r - 128) <= 3
    assert abs(px(d, (60, 20)) - (200, 40, 40)).max() <= 2  # the layer is over it
    d.key(key.S, key.MOD_CTRL)
    d.settle()
    import json

    saved = json.loads(open(d.app.snap.file).read())
    assert saved["app"]["underlay"]["image"] == "ref.png"
    import puppet

    again = puppet.load_scene(d.app.snap.file)  # render ignores the app's key
    try:
        np.testing.assert_array_equal(again.render(pose="bend"), d.scene().render(pose="bend"))
        again.set_underlay(None)
        np.testing.assert_array_equal(again.render(pose="bend"), d.scene().render(pose="bend"))
    finally:
        again.close()


def test_checkerboard_behind_transparency(make_scene):
    from tests.app.harness import Driver
    from tests.conftest import bar_image, bar_scene

    doc = dict(bar_scene(), background=[0, 0, 0, 0])
    d = Driver(make_scene(doc, {"bar.png": bar_image()}))
    try:
        d.key(key.H)
        x0, y0 = (int(v) for v in d.screen_of((2, 2)))
        x1, y1 = (int(v) for v in d.screen_of((118, 8)))
        greys = d.pixels()[y0:y1, x0:x1].reshape(-1, 3)
        assert set(np.unique(greys[:, 0]).tolist()) == {204, 255}  # two greys, nothing else
        assert (greys[:, 0] == greys[:, 1]).all()
        assert abs(px(d, (60, 20)) - (200, 40, 40)).max() <= 2
    finally:
        d.close()


def test_resizing_keeps_a_fitted_canvas_fitted(bar_app):
    # a headless window cannot be resized: feed the canvas area a resize would give
    app = bar_app.app
    x, y, w, h = app.area
    w0 = app.view.canvas_rect(app.snap.canvas)[2]
    app.set_area((x, y, w + 300, h + 200))
    assert app.view.canvas_rect(app.snap.canvas)[2] > w0 + 100  # refitted
    app.zoom((300, 300), 1)  # zoomed by hand: a resize leaves the view alone
    view = (app.view.scale, app.view.origin)
    app.set_area((x, y, w, h))
    assert (app.view.scale, app.view.origin) == view


def test_every_button_has_a_tooltip():
    """Buttons go through widgets.button (tooltip argument required), never bare."""
    root = os.path.join(ROOT, "puppet", "app")
    names = [os.path.relpath(os.path.join(dp, f), root) for dp, _, fs in os.walk(root) for f in fs]
    assert "ui/panels.py" in names
    for name in names:
        if name.endswith(".py") and name != os.path.join("ui", "widgets.py"):
            text = open(os.path.join(root, name)).read()
            assert not re.search(r"imgui\.(small_)?button\(", text), name
            for m in re.finditer(r"imgui\.(checkbox|radio_button|slider_float|combo|drag_float2?)\(", text):
                after = text[m.end():m.end() + 400]
                assert "set_item_tooltip" in after, f"{name}: {m.group(0)} without a tooltip"


def test_the_layers_panel_keeps_the_exact_mesh_sizes_during_a_coarse_preview(monkeypatch):
    """A big group's drag previews are its reduced model's coarse meshes: the Layers panel
    still names the exact meshes' vertices and triangles while the pin is held."""
    from puppet.scene.rig import reduced
    from tests.app.harness import Driver

    monkeypatch.setattr(reduced, "REDUCED_MIN", 0)  # the T-rex's 7.7k vertices count as big
    monkeypatch.setattr(reduced, "MAX_SHARE", np.inf)
    d = Driver(os.path.join(ROOT, "assets", "scenes", "trex-layers.json"), size=(1100, 700))
    try:
        exact = {r.name: (len(r.rest), len(r.triangles)) for r in d.app.snap.layers}
        start = d.pin_screen("hand_front")
        d.press(*start)
        for k in range(1, 4):
            d.drag(start[0] + 4 * k, start[1] - 4 * k)
        d.settle()
        shown = {r.name: len(r.rest) for r in d.app.snap.layers}
        assert d.app.snap.preview and any(shown[n] < exact[n][0] for n in exact)  # coarse meshes drawn
        d.frame()
        assert d.w.panels._sizes == exact
        d.release()
        d.settle()
        assert d.w.panels._sizes == exact
    finally:
        d.close()
