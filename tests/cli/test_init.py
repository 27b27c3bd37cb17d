"""`puppet init IMAGE -o SCENE.json`: a one-layer scene and its mask from a picture."""
import json
import os

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

import puppet
from puppet.cli import main
from puppet.imaging.skeleton import auto_pins, skeleton, skeleton_points
from tests.conftest import ASSETS, write_rgba

HORSE = os.path.join(ASSETS, "horse", "horse.png")  # black on white, opaque-ish
RUNNER = os.path.join(ASSETS, "noto-emoji", "emoji_u1f3c3.png")  # RGBA with transparency


def rgba_of(path):
    with Image.open(path) as im:
        return np.array(im.convert("RGBA"))


def mask_of(path):
    with Image.open(path) as im:
        assert im.mode == "L"
        return np.array(im) > 0


def pins_of(scene):
    return {p["name"]: p["at"] for p in json.loads(open(scene).read()).get("pins", [])}


def assert_well_inside(mask, pins, margin=2):
    for name, (x, y) in pins.items():
        i, j = int(np.floor(y)), int(np.floor(x))
        assert (x - j, y - i) == (0.5, 0.5), name  # a pixel centre
        assert mask[i - margin:i + margin + 1, j - margin:j + margin + 1].all(), (name, x, y)


def assert_rest_equals_picture(rest, rgba, mask, tol=2, holes=0.0002):
    """The rest pose shows the picture on the mask: premultiplied colours and alpha within
    ``tol`` grey levels (straight colours of faint pixels are quantised by the blending),
    except at most a fraction ``holes`` of mask pixels (the mesh misses a few pixels on
    one-pixel diagonal steps of the outline: 3 of 43 412 on the horse)."""
    def premultiplied(a):
        a = a.astype(np.float64)
        return np.concatenate([a[..., :3] * a[..., 3:] / 255, a[..., 3:]], -1)
    diff = np.abs(premultiplied(rest) - premultiplied(rgba)).max(-1)[mask]
    assert (diff > tol).mean() <= holes, ((diff > tol).sum(), mask.sum())
    assert np.median(diff) == 0


# -- the skeleton on hand-checked shapes ------------------------------------------------
def plus_shape():
    m = np.zeros((101, 101), bool)
    m[45:56, 5:96] = True
    m[5:96, 45:56] = True
    return m


def test_plus_has_four_ends_and_one_junction():
    ends, joints = skeleton_points(skeleton(plus_shape()))
    assert len(ends) == 4 and len(joints) == 1
    assert np.abs(joints[0] - 50).max() <= 2
    tips = sorted(map(tuple, ends))
    # one tip per arm, near the arm's end (thinning stops short of the edge by about the half width)
    assert all(min(abs(r - 50), abs(c - 50)) <= 2 and max(abs(r - 50), abs(c - 50)) >= 35 for r, c in tips)


def test_staircase_diagonal_is_one_branch():
    # a thick diagonal band: Zhang-Suen gives a staircase whose steps have 3 neighbours
    yy, xx = np.mgrid[0:120, 0:120]
    m = (np.abs(yy - 0.6 * xx - 20) < 6) & (xx > 5) & (xx < 115)
    ends, joints = skeleton_points(skeleton(m))
    assert len(ends) == 2 and len(joints) == 0


def test_auto_pins_plus_names_and_margin():
    m = plus_shape()
    pins = auto_pins(m)
    kinds = sorted(p.kind for p in pins)
    assert kinds == ["end"] * 4 + ["joint"]
    assert sorted(p.name for p in pins) == ["end1", "end2", "end3", "end4", "joint1"]
    assert_well_inside(m, {p.name: p.at for p in pins})
    (joint,) = [p for p in pins if p.kind == "joint"]
    assert np.hypot(joint.at[0] - 50.5, joint.at[1] - 50.5) <= 3


def test_auto_pins_limit_specks_and_thin_parts():
    m = plus_shape()
    m[0, 0] = m[99, 2] = True          # specks: no pins
    m[2:5, 70:100] = True              # a 3 px thin strip: its own component, pinned on its middle row
    pins = auto_pins(m)
    assert all(not (x < 3 and y < 3) and not (y > 98 and x < 4) for x, y in (p.at for p in pins))
    strip = [p for p in pins if p.at[1] < 5]
    assert strip and all(p.at[1] == 3.5 for p in strip)
    assert len(auto_pins(m, max_pins=3)) == 3
    assert auto_pins(np.zeros((10, 10), bool)) == []


# -- the command --------------------------------------------------------------------------
def run_init(tmp_path, image, *flags, name="scene.json"):
    out = tmp_path / name
    code = main(["init", image, "-o", str(out), *flags])
    return code, str(out)


@pytest.mark.gl
def test_init_horse_threshold_auto_pins(tmp_path, capsys):
    code, out = run_init(tmp_path, HORSE, "--threshold", "128", "--pins", "auto")
    assert code == 0
    assert sorted(os.listdir(tmp_path)) == ["scene-mask.png", "scene.json"]
    doc = json.loads(open(out).read())
    assert doc["layers"] == [{"name": "horse", "mask": {"file": "scene-mask.png"}}]
    assert os.path.normpath(os.path.join(tmp_path, doc["source"])) == os.path.normpath(HORSE)
    rgba = rgba_of(HORSE)
    mask = mask_of(tmp_path / "scene-mask.png")
    luma = rgba[..., :3].astype(np.float64) @ [0.299, 0.587, 0.114]
    assert np.array_equal(mask, (luma < 128) & (rgba[..., 3] > 0))
    assert 40_000 < mask.sum() < 47_000  # the horse covers about a third of 400x328
    assert ndimage.label(mask, np.ones((3, 3)))[1] == 1
    line = capsys.readouterr().out
    assert f"mask (threshold 128) {int(mask.sum())} px" in line and "1 component(s)" in line

    pins = pins_of(out)
    assert 6 <= len(pins) <= 16
    assert_well_inside(mask, pins)
    xy = np.array(list(pins.values()))
    assert (xy[:, 1] > 290).sum() >= 3      # hooves
    assert (xy[:, 0] > 340).any()           # the head
    assert main(["check", out]) == 0

    scene = puppet.load_scene(out)
    rest = scene.render()
    assert_rest_equals_picture(rest, rgba, mask)
    far = ~ndimage.binary_dilation(mask, iterations=2)
    assert rest[far][:, 3].max() == 0
    name, (x, y) = next((n, p) for n, p in pins.items() if n.startswith("end") and p[0] > 340)
    moved = scene.render(pose={name: [x + 15, y - 25]})
    assert moved.shape == rest.shape and np.isfinite(moved).all()
    diff = np.abs(moved.astype(int) - rest.astype(int)).sum(-1) > 60
    assert diff[:, 300:].mean() > 0.02 and diff[:, :60].mean() < 0.1 * diff[:, 300:].mean()  # head moves, tail hardly
    mesh = scene.mesh(pose={name: [x + 15, y - 25]})["layers"][0]
    assert np.allclose(mesh["deformed"][mesh["pins"][name]], [x + 15, y - 25])
    assert np.isfinite(mesh["deformed"]).all()
    scene.close()


@pytest.mark.gl
def test_init_default_rule_is_alpha_for_transparent_pictures(tmp_path):
    code, out = run_init(tmp_path, RUNNER, "--pins", "auto", name="run.json")
    assert code == 0
    rgba = rgba_of(RUNNER)
    mask = mask_of(tmp_path / "run-mask.png")
    assert np.array_equal(mask, rgba[..., 3] > 0)
    assert ndimage.label(mask, np.ones((3, 3)))[1] == 1
    pins = pins_of(out)
    assert 4 <= len(pins) <= 16
    assert_well_inside(mask, pins)
    scene = puppet.load_scene(out)
    assert_rest_equals_picture(scene.render(), rgba, mask)
    scene.close()
    code, out2 = run_init(tmp_path, RUNNER, "--alpha", name="run2.json")
    assert code == 0 and np.array_equal(mask_of(tmp_path / "run2-mask.png"), mask)
    assert "pins" not in json.loads(open(out2).read())


def test_init_grabcut_finds_a_disc_on_noise(tmp_path):
    rng = np.random.default_rng(0)
    a = np.zeros((90, 100, 4), np.uint8)
    a[..., :3] = rng.integers(90, 140, (90, 100, 3))
    a[..., 3] = 255
    yy, xx = np.mgrid[0:90, 0:100]
    disc = (yy - 45) ** 2 + (xx - 50) ** 2 < 25 ** 2
    a[disc, :3] = (220, 30, 30)
    img = write_rgba(tmp_path / "photo.png", a)
    code, out = run_init(tmp_path, str(img), "--grabcut", "15,10,70,70", "--pins", "auto")
    assert code == 0
    mask = mask_of(tmp_path / "scene-mask.png")
    assert (mask ^ disc).sum() < 0.03 * disc.sum()
    pins = pins_of(out)
    assert len(pins) >= 1
    assert_well_inside(mask, pins)
    assert main(["check", out]) == 0


@pytest.mark.parametrize("argv, message", [
    (["-o", "{d}/s.png"], "the output must end in .json"),
    (["-o", "{d}/s.json", "--grabcut", "1,2,3"], "expected X,Y,W,H"),
    (["-o", "{d}/s.json", "--threshold", "300"], "0..256"),
    (["-o", "{d}/s.json", "--threshold", "0"], "selects no pixels"),
    (["-o", "{d}/s.json", "--grabcut", "500,500,20,20"], "outside the"),
    (["-o", "{d}/s.json", "--alpha", "--threshold", "9"], "not allowed with"),
    (["-o", "{d}/nowhere/s.json"], "does not exist"),
])
def test_init_errors_write_nothing(tmp_path, capsys, argv, message):
    img = write_rgba(tmp_path / "in.png", np.full((20, 30, 4), 40, np.uint8) | np.array([0, 0, 0, 255], np.uint8))
    before = sorted(os.listdir(tmp_path))
    assert main(["init", str(img), *[a.format(d=tmp_path) for a in argv]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("puppet: error: ") and message in err[0], err
    assert sorted(os.listdir(tmp_path)) == before


def test_init_never_overwrites_the_picture(tmp_path, capsys):
    a = np.zeros((20, 30, 4), np.uint8)
    a[5:15, 5:25] = 255
    img = write_rgba(tmp_path / "s-mask.png", a)
    data = open(img, "rb").read()
    assert main(["init", str(img), "-o", str(tmp_path / "s.json")]) == 2
    assert "it is a file the scene reads" in capsys.readouterr().err
    assert open(img, "rb").read() == data and sorted(os.listdir(tmp_path)) == ["s-mask.png"]
    assert main(["init", str(tmp_path / "missing.png"), "-o", str(tmp_path / "t.json")]) == 2
    assert sorted(os.listdir(tmp_path)) == ["s-mask.png"]


def test_init_writes_both_or_neither(tmp_path, monkeypatch):
    import puppet.output
    from puppet.output import OutputError

    real = puppet.output.Staged.__init__

    def fail(self, path, write, **kw):  # the scene (staged after the mask) finds the disk full
        if path.endswith(".json"):
            raise OutputError(path, "No space left on device")
        real(self, path, write, **kw)
    monkeypatch.setattr(puppet.output.Staged, "__init__", fail)
    code, out = run_init(tmp_path, HORSE, "--threshold", "128")
    assert code == 2 and os.listdir(tmp_path) == []
    monkeypatch.undo()
    commit = puppet.output.Staged.commit

    def fail_second(self):  # the mask is in place, the scene's rename fails: the mask is taken back
        if self.path.endswith(".json"):
            raise OutputError(self.path, "Input/output error")
        commit(self)
    monkeypatch.setattr(puppet.output.Staged, "commit", fail_second)
    code, out = run_init(tmp_path, HORSE, "--threshold", "128")
    assert code == 2 and os.listdir(tmp_path) == []
