"""The puppet command end to end with real GL (EGL), real files and real encoders."""
import json
import os

import numpy as np
import pytest
from PIL import Image

import puppet
from puppet.cli import main
from tests.conftest import SCENES

pytestmark = pytest.mark.gl


def png(path):
    with Image.open(path) as im:
        return np.array(im.convert("RGBA"))


def test_render_rest_matches_the_layers(bar, tmp_path):
    out = tmp_path / "o.png"
    assert main(["render", bar, "-o", str(out)]) == 0
    a = png(out)
    assert a.shape == (40, 120, 4)
    assert tuple(a[20, 60]) == (200, 40, 40, 255)   # the bar
    assert tuple(a[2, 2]) == (255, 255, 255, 255)   # the background
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bar.png", "o.png", "scene.json"]


def test_render_pose_moves_pixels_and_size_scales(bar, tmp_path):
    main(["render", bar, "--pose", "bend", "-o", str(tmp_path / "b.png")])
    b = png(tmp_path / "b.png")
    assert tuple(b[6, 100][:3]) == (200, 40, 40)      # the dragged end is up there now
    assert tuple(b[25, 100][:3]) == (255, 255, 255)   # and no longer where it was
    main(["render", bar, "--pose", "bend", "--size", "60x20", "-o", str(tmp_path / "s.png")])
    s = png(tmp_path / "s.png")
    assert s.shape == (20, 60, 4)
    small = np.array(Image.fromarray(b).resize((60, 20), Image.BILINEAR)).astype(int)
    assert np.mean(np.abs(small - s.astype(int))) < 12


def test_wireframe_draws_edges(bar, tmp_path):
    main(["render", bar, "-o", str(tmp_path / "a.png")])
    main(["render", bar, "--wireframe", "-o", str(tmp_path / "w.png")])
    a, w = png(tmp_path / "a.png").astype(int), png(tmp_path / "w.png").astype(int)
    changed = np.abs(a - w).sum(-1) > 0
    assert changed[10:31, 9:112].mean() > 0.2 and not changed[:5, :].any()


def test_time_and_mesh_command(bar, tmp_path):
    assert main(["mesh", bar, "--time", "0.5", "-o", str(tmp_path / "m.json")]) == 0
    m = json.loads((tmp_path / "m.json").read_text())
    L = m["layers"][0]
    # the frame at 0.5 s is the scene's own in-between (rigid by default: the bar turns
    # about the still left pin, so the right pin keeps its distance, 86.3..90 px)
    assert np.allclose(L["deformed"], puppet.load_scene(bar).layers(time=0.5)[0].deformed, atol=1e-9)
    x, y = L["deformed"][L["pins"]["right"]]
    assert 86.3 < np.hypot(x - 15, y - 20) < 90 and 5 < y < 20


@pytest.mark.parametrize("out", ["frames/", "anim.gif", "anim.mp4"])
def test_animate_outputs(bar, tmp_path, out):
    target = tmp_path / out
    arg = str(target) + ("/" if out.endswith("/") else "")  # pathlib drops the trailing slash
    assert main(["animate", bar, "-o", arg]) == 0
    if out.endswith("/"):
        names = sorted(os.listdir(target))
        assert names == [f"frame_{i:05d}.png" for i in range(11)]
        assert png(target / names[-1]).shape == (40, 120, 4)
    elif out.endswith(".gif"):
        with Image.open(target) as im:
            assert im.n_frames == 11 and im.size == (120, 40) and im.info["duration"] == 100
    else:
        import av
        with av.open(str(target)) as box:
            st = box.streams.video[0]
            frames = list(box.decode(st))
            assert st.codec_context.name == "h264" and len(frames) == 11
            assert (frames[0].width, frames[0].height) == (120, 40)
    leftovers = [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert leftovers == []


def test_animate_range_and_fps(bar, tmp_path):
    main(["animate", bar, "-o", str(tmp_path / "f") + "/", "--fps", "4", "--from", "0.5", "--to", "1"])
    assert len(os.listdir(tmp_path / "f")) == 3


def test_strips_depth_decides_the_crossing(tmp_path):
    """The acceptance scene: blue is in front at rest (later layer), red with depth +2."""
    scene = os.path.join(SCENES, "strips.json")
    for pose, want in (("rest", (40, 60, 220)), ("red_front", (220, 40, 40))):
        out = tmp_path / f"{pose}.png"
        assert main(["render", scene, "--pose", pose, "-o", str(out)]) == 0
        assert np.abs(png(out)[200, 200, :3].astype(int) - want).max() <= 8


def arm_over_body(make_scene, hand_depth):
    """A green body (back) and a red arm (front) lying across it, linked at the shoulder."""
    body = np.zeros((100, 160, 4), np.uint8)
    body[20:80, 20:140] = (40, 170, 60, 255)
    arm = np.zeros((100, 160, 4), np.uint8)
    arm[44:56, 10:150] = (210, 40, 40, 255)
    s = {"puppet": 1, "canvas": [160, 100], "background": [255, 255, 255, 255],
         "layers": [{"name": "body", "image": "body.png"}, {"name": "arm", "image": "arm.png"}],
         "links": [{"layers": ["body", "arm"], "segments": [[[128, 46], [128, 54]]]}],
         "pins": [{"name": "hip", "layer": "body", "at": [60, 70]},
                  {"name": "neck", "layer": "body", "at": [100, 30]},
                  {"name": "hand", "layer": "arm", "at": [15, 50], "depth": hand_depth}]}
    return puppet.load_scene(make_scene(s, {"body.png": body, "arm.png": arm}, name=f"s{hand_depth}.json"))


def test_limb_passes_behind_the_body_and_stays_in_front_at_its_other_end(make_scene):
    front = arm_over_body(make_scene, 0.0).render()
    assert tuple(front[50, 40, :3]) == (210, 40, 40) and tuple(front[50, 120, :3]) == (210, 40, 40)
    sc = arm_over_body(make_scene, -3.0)
    img = sc.render()
    arm = sc.layers()[1]
    assert arm.depth[arm.pins["hand"]] == pytest.approx(-2.0)
    assert tuple(img[50, 40, :3]) == (40, 170, 60), "near the hand the arm is behind the body"
    assert tuple(img[50, 125, :3]) == (210, 40, 40), "at the shoulder it is still in front"
    assert tuple(img[50, 14, :3]) == (210, 40, 40), "outside the body the arm shows"


def png_layer_colour(sc, name, x, y):
    im = sc.images[[L.name for L in sc.data.layers].index(name)]
    return im.rgba[y - int(im.offset[1]), x - int(im.offset[0])].astype(int)


def test_save_load_render_identical(tmp_path):
    sc = puppet.load_scene(os.path.join(SCENES, "trex-cutout.json"))
    sc.save(str(tmp_path / "copy.json"))
    again = puppet.load_scene(str(tmp_path / "copy.json"))
    assert np.array_equal(sc.render(pose="reach"), again.render(pose="reach"))
