"""The task script walked with synthetic events on a flat picture (the bundled noto-emoji
runner flattened onto white, 256x256): Image (threshold slider, brush - and +), Layers
(+, a lasso clone of the front arm, the body's refill, a paint stroke), Link (a segment
with nothing in the intersection is refused, one that leaves it keeps its part inside), Pins, Deform, a drag,
Ctrl+S; the saved scene renders through the CLI to the canvas's pixels."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image
from pyglet.window import key

import puppet
from puppet.app.ui.widgets import RECTS
from tests.app.harness import Driver, widget

pytestmark = pytest.mark.gl

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RUNNER = os.path.join(ROOT, "assets", "noto-emoji", "emoji_u1f3c3.png")
#: the front arm (fist to shoulder, with the sleeve) on the 256x256 picture
ARM = [(56, 70), (94, 66), (106, 88), (118, 94), (116, 108), (92, 108), (56, 100)]
FIST = (75.0, 85.0)
SHOULDER = [(96.0, 99.0), (112.0, 97.0)]  # inside the arm, so inside both masks
OUTSIDE = [(104.0, 62.0), (104.0, 40.0)]  # above the arm: nothing of it where the two layers overlap
ACROSS = [(90.0, 98.0), (135.0, 96.0)]  # from the shoulder out across the shirt: the part on the arm is kept


def flat_runner(folder) -> str:
    im = Image.open(RUNNER).convert("RGBA")
    flat = Image.new("RGBA", im.size, (255, 255, 255, 255))
    flat.alpha_composite(im)
    path = os.path.join(str(folder), "runner.png")
    flat.convert("RGB").resize((256, 256), Image.LANCZOS).save(path)
    return path


def mask_of(d, name) -> np.ndarray:
    s = d.scene()
    k = [L.name for L in s.data.layers].index(name)
    return s.built.images[k].mask


def click_widget(d, label, settle=True):
    d.click(*widget(label))
    if settle:
        d.settle()


def stroke(d, points):
    d.drag_path([d.screen_of(p) for p in points])
    d.settle()


def walk(d, shots=None):
    """The whole task script; ``shots(name)`` is called at each step (screenshots)."""
    app = d.app
    shot = shots or (lambda name: None)
    # 1. Image: a new scene in the Image step
    assert app.script.step == "image" and app.mode == "pin" and d.scene().data.source.endswith("runner.png")
    x0, y0, x1, y1 = RECTS["frame:threshold"]

    d.click(x0 + 0.9 * (x1 - x0), (y0 + y1) / 2)  # about 230: the yellow skin (luminance ~200) is in
    d.settle()
    L = d.scene().data.layers[0]

    assert L.mask.kind == "threshold" and 215 < L.mask.threshold < 248, L.mask
    assert L.mask.threshold == pytest.approx(app.script.threshold)
    toe = (214.0, 176.0)  # the back shoe's toe
    assert mask_of(d, "layer1")[int(toe[1]), int(toe[0])]
    click_widget(d, "tool:brush-sub")
    stroke(d, [toe, (toe[0] + 1, toe[1] + 1)])
    assert not mask_of(d, "layer1")[int(toe[1]), int(toe[0])]
    click_widget(d, "tool:brush-add")
    stroke(d, [toe, (toe[0] + 1, toe[1] + 1)])
    assert mask_of(d, "layer1")[int(toe[1]), int(toe[0])]
    assert d.scene().data.layers[0].mask.kind == "file"
    shot("script-image")
    # 2. Layers: + then a lasso around the front arm clones it into the new layer
    click_widget(d, "step:layers")
    assert app.script.step == "layers" and app.script.tool == "lasso"
    click_widget(d, "+")
    assert app.script.pending == "layer2" and len(d.scene().data.layers) == 1  # empty: app-only
    stroke(d, ARM + [ARM[0]])
    names = [L.name for L in d.scene().data.layers]
    assert names == ["layer1", "layer2"]
    arm = mask_of(d, "layer2")
    assert arm[int(FIST[1]), int(FIST[0])] and arm.sum() > 800
    assert not arm[:, :50].any() and not arm[110:].any() and not arm[:64].any()  # only inside the lasso
    assert arm.sum() == (arm & mask_of(d, "layer1")).sum()  # of the object, not the white around it
    assert app.script.pending is None
    # the body refills where the arm was (before/after preview), Telea
    click_widget(d, "layer:layer1")
    click_widget(d, "inpaint:telea")
    assert d.scene().data.layers[0].inpaint == "telea"
    body = d.scene().built.images[0].rgba
    src = np.asarray(Image.open(d.scene().data.source).convert("RGBA"))
    assert np.abs(body[85, 75, :3].astype(int) - src[85, 75, :3]).max() > 20  # fist area refilled
    shot("script-layers")
    # paint a stroke of colour on the body's shirt
    click_widget(d, "tool:paint")
    stroke(d, [(140, 112), (150, 112)])
    assert app.status.level == "info", app.status.text
    body = d.scene().built.images[0].rgba
    color = np.array([round(c * 255) for c in app.script.color[:3]])
    assert np.abs(body[112, 145, :3].astype(int) - color).max() <= 1
    assert np.abs(body[85, 75, :3].astype(int) - src[85, 75, :3]).max() > 20  # refill kept
    # 3. Link: a segment outside the intersection is refused, one that leaves it keeps its part inside
    click_widget(d, "step:link")
    assert app.script.link_pair(app) == ("layer1", "layer2") and app.script.tool == "link"
    steps = len(d.scene().history.undo_stack)
    stroke(d, OUTSIDE)
    assert app.status.level == "error" and "no part of the segment" in app.status.text, app.status.text
    assert app.script.link_preview.kept is None and not d.scene().data.links
    assert len(d.scene().history.undo_stack) == steps
    d.press(*d.screen_of(ACROSS[0]))
    d.drag(*d.screen_of(ACROSS[1]))
    p = app.script.link_preview  # the live preview: kept where the arm lies on the body
    assert p.kept is not None and not p.done and len(p.dropped()) == 1
    assert 110 < max(p.kept[:, 0]) < 120 and min(p.kept[:, 0]) == pytest.approx(90, abs=1)
    shot("script-link")
    d.release(*d.screen_of(ACROSS[1]))
    d.settle()
    links = d.scene().data.links
    assert len(links) == 1 and set(links[0].layers) == {"layer1", "layer2"}
    np.testing.assert_array_equal(links[0].segments[0], p.kept)  # what the preview showed kept
    assert len(d.scene().history.undo_stack) == steps + 1
    assert app.status.level == "info" and app.status.text.startswith("link kept"), app.status.text
    # 4. Pins: the fist on the arm, three on the body; automatic exterior points on the arm
    click_widget(d, "step:pins")
    assert app.mode == "pin" and app.script.tool is None
    click_widget(d, "layer:layer1")  # in this step a pin goes on the layer seen there, whatever is selected
    for p in (FIST, (135.0, 100.0), (78.0, 226.0), (200.0, 168.0)):
        d.click(*d.screen_of(p))
        d.settle()
    pins = {p.name: p for p in d.scene().data.pins}
    assert [p.layer for p in pins.values()] == ["layer2", "layer1", "layer1", "layer1"]
    click_widget(d, "layer:layer2")
    click_widget(d, "check:exterior")
    assert d.scene().data.layers[1].exterior is not None
    assert any(m.kind == "auto" for m in app.markers())
    shot("script-pins")
    # 5. Deform: meshes built and shown, Pose mode; drag the fist up
    click_widget(d, "step:deform")
    assert app.mode == "pose" and app.show_mesh and "meshes built" in app.status.text
    fist = d.pin_screen("pin1")
    s = app.view.scale
    d.drag_path([fist, (fist[0] + 3, fist[1] - 3), (fist[0] + 10 * s, fist[1] - 30 * s)])
    d.settle()
    pose = d.scene().active_pose
    assert pose != "rest"
    t = d.scene().data.poses[pose]["pin1"].to
    assert t[1] < FIST[1] - 20
    shot("script-deform")
    # Ctrl+S: the scene and its painted masks/pixels beside the picture
    d.key(key.S, key.MOD_CTRL)
    d.settle()
    return pose


@pytest.mark.slow
def test_task_script_from_a_flat_picture(tmp_path):
    picture = flat_runner(tmp_path)
    d = Driver(picture, size=(960, 640))
    try:
        pose = walk(d)
        t0 = d.scene().data.poses[pose]["pin1"].to
        app = d.app
        path = str(tmp_path / "runner.json")
        assert app.snap.file == path and not app.snap.dirty and os.path.isfile(path)
        assert os.path.isdir(str(tmp_path / "runner.files"))
        saved = puppet.load_scene(path)
        assert [L.name for L in saved.data.layers] == ["layer1", "layer2"] and saved.data.links
        # the canvas at 100 % with pins, mesh and the tint hidden
        app.show_pins = app.show_mesh = app.show_links = False
        app.script.step = "pose"
        d.key(key._1, key.MOD_CTRL)
        app.view.origin = tuple(float(round(v)) for v in app.view.origin)  # on whole pixels
        d.settle()
        window = d.pixels()  # before anything else makes its own GL context current
        out = tmp_path / "cli.png"
        r = subprocess.run([sys.executable, "-m", "puppet", "render", path, "-o", str(out), "--pose", pose],
                           capture_output=True, text=True, cwd=ROOT)
        assert r.returncode == 0, r.stderr
        cli = np.asarray(Image.open(out).convert("RGBA")).astype(int)
        np.testing.assert_array_equal(cli, saved.render(pose=pose).astype(int))
        x, y, w, h = app.view.canvas_rect(app.snap.canvas)
        assert app.view.scale == 1.0 and (w, h) == (256, 256)
        screen = window[int(round(y)):int(round(y)) + 256, int(round(x)):int(round(x)) + 256].astype(int)
        opaque = cli[..., 3] == 255
        assert opaque.sum() > 10000
        diff = np.abs(screen[opaque] - cli[..., :3][opaque])
        assert np.percentile(diff, 99) <= 3 and diff.mean() < 1.0
        saved.close()
        # back to Image: a lower threshold; links, pins and the pose keep working
        click_widget(d, "step:image")
        x0, y0, x1, y1 = RECTS["frame:threshold"]
        d.click(x0 + 0.85 * (x1 - x0), (y0 + y1) / 2)
        d.settle()
        s = d.scene()
        assert s.data.layers[0].mask.kind == "threshold" and app.status.level == "info", app.status.text
        assert len(s.data.links) == 1 and len(s.data.pins) == 4
        click_widget(d, "step:pose")
        app.show_pins = True
        fist = d.pin_screen("pin1")
        d.drag_path([fist, (fist[0] + 3, fist[1]), (fist[0] + 20, fist[1] + 10)])
        d.settle()
        assert app.status.level == "info" and d.scene().data.poses[d.scene().active_pose]["pin1"].to[0] > t0[0]
    finally:
        d.close()


def test_undo_goes_back_through_the_steps(tmp_path):
    d = Driver(flat_runner(tmp_path), size=(960, 640))
    try:
        click_widget(d, "step:layers")
        click_widget(d, "+")
        stroke(d, ARM + [ARM[0]])
        assert len(d.scene().data.layers) == 2
        d.key(key.Z, key.MOD_CTRL)
        d.settle()
        assert len(d.scene().data.layers) == 1  # the clone into a new layer is one step
        # a rectangle clone: the object's pixels inside the box
        click_widget(d, "+")
        click_widget(d, "tool:clone-rect")
        stroke(d, [(60, 72), (75, 85), (92, 98)])
        fist = mask_of(d, "layer2")
        box = np.zeros_like(fist)
        box[72:98, 60:92] = True
        assert fist.any() and not (fist & ~box).any()
        assert (fist == (box & mask_of(d, "layer1"))).mean() > 0.99  # up to the box's rounded edges
        d.key(key.Z, key.MOD_CTRL)
        d.settle()
        # erasing every pixel of the only layer is refused, with the reason
        click_widget(d, "tool:erase")
        assert d.app.script.tool == "erase"
        d.app.script.brush = 120.0
        before = mask_of(d, "layer1").sum()
        stroke(d, [(128, 128), (129, 129)])
        assert mask_of(d, "layer1").sum() < before  # a bite out of it
    finally:
        d.close()


def test_grabcut_box_alpha_and_exterior_beta(tmp_path):
    """Image: a GrabCut rectangle dragged around the runner, then Alpha on a picture with
    transparency; Pins: the beta slider changes the number of automatic exterior points."""
    d = Driver(flat_runner(tmp_path))
    try:
        app = d.app
        click_widget(d, "tool:grabcut")
        stroke(d, [(40, 20), (120, 120), (240, 245)])
        L = d.scene().data.layers[0]
        assert L.mask.kind == "grabcut" and np.allclose(L.mask.rect, [40, 20, 200, 225], atol=1)
        m = mask_of(d, "layer1")
        assert m[100, 135] and not m[5, 5] and not m[:18].any()  # the torso in, the corner out
        click_widget(d, "step:pins")
        click_widget(d, "check:exterior")
        assert d.scene().data.layers[0].exterior.beta == pytest.approx(1.0)
        few = sum(m.kind == "auto" for m in app.markers())
        x0, y0, x1, y1 = RECTS["slider:beta"]
        d.click(x0 + 0.72 * (x1 - x0), (y0 + y1) / 2)  # near the right end (logarithmic 0.2..8)
        d.settle()
        beta = d.scene().data.layers[0].exterior.beta
        many = sum(m.kind == "auto" for m in app.markers())
        assert beta > 3 and many > few >= 1
        d.key(key.Z, key.MOD_CTRL)  # the slider drag is one undo step
        d.settle()
        assert d.scene().data.layers[0].exterior.beta == pytest.approx(1.0)
    finally:
        d.close()
    # a picture with transparency: the first layer takes its alpha
    d = Driver(RUNNER)
    try:
        click_widget(d, "Alpha")
        assert d.scene().data.layers[0].mask.kind == "alpha"
        assert mask_of(d, "layer1").sum() == (np.asarray(Image.open(RUNNER))[..., 3] > 0).sum()
    finally:
        d.close()


def test_links_listed_and_removable(tmp_path):
    d = Driver(flat_runner(tmp_path))
    try:
        click_widget(d, "step:layers")
        click_widget(d, "+")
        click_widget(d, "field:layer name")  # the new, still empty layer is named before its first clone
        d.type("arm")
        d.key(key.ENTER)
        stroke(d, ARM + [ARM[0]])
        click_widget(d, "layer:layer1")
        click_widget(d, "field:layer name")
        d.type("body")
        d.key(key.ENTER)
        d.settle()
        assert [L.name for L in d.scene().data.layers] == ["body", "arm"]
        click_widget(d, "step:link")
        tint = d.app.script.tint(d.app)[1]  # the intersection: the arm (all of it lies on the body)
        np.testing.assert_array_equal(tint[..., 3] > 0, mask_of(d, "arm"))
        click_widget(d, "check:tint")
        assert d.app.script.tint(d.app) is None
        stroke(d, SHOULDER)
        assert len(d.scene().data.links) == 1
        click_widget(d, "x")  # the list's remove button of that segment
        assert not d.scene().data.links
        d.key(key.Z, key.MOD_CTRL)
        d.settle()
        assert len(d.scene().data.links) == 1
    finally:
        d.close()


def test_file_open_a_picture_and_its_autosave(tmp_path):
    """File > Open with a picture starts the task script; after a crash the unsaved scene
    over the picture is offered back from its autosave; a saved scene beside it is not
    overwritten by a new one."""

    picture = flat_runner(tmp_path)
    d = Driver()
    try:
        d.key(key.O, key.MOD_CTRL)
        d.key(key.A, key.MOD_CTRL)
        d.type(picture)
        d.key(key.ENTER)
        d.settle()
        assert d.app.snap.loaded and d.app.script.step == "image" and d.app.title == "puppet — runner.json *"
        click_widget(d, "step:layers")
        click_widget(d, "+")
        stroke(d, ARM + [ARM[0]])
        d.app.autosave()  # the minute's autosave
        d.settle()
    finally:
        d.app.session.wait_idle()
        d.w.closed = True  # a crash: no clean close (the autosave stays)
        d.app.session.stop()
        d.w.win.close()
    assert os.path.isfile(str(tmp_path / "runner.autosave.json"))
    d = Driver(picture)
    try:
        assert d.app.dialog == "recover"
        d.w.recover(True)
        d.settle()
        assert [L.name for L in d.scene().data.layers] == ["layer1", "layer2"]
        assert d.app.snap.file == str(tmp_path / "runner.json") and d.app.snap.dirty
        d.key(key.S, key.MOD_CTRL)
        d.settle()
        assert os.path.isfile(str(tmp_path / "runner.json"))
    finally:
        d.close()
    d = Driver(picture)  # runner.json exists now: refused, with the reason
    try:
        assert not d.app.snap.loaded and "exists beside the picture" in d.app.status.text
    finally:
        d.close()
