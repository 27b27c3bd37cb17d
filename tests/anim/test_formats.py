"""Every export format read back by a real decoder and compared with the PNG frames:
WebM (libvpx-vp9 decoder, alpha), APNG (Pillow, per-frame durations), sprite sheet
(atlas regions), MP4, GIF (frame times, transparency); --background colours."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest
from PIL import Image

from puppet.cli import main
from tests.anim.test_export import pngs
from tests.cli.outputs_helpers import make_bar

pytestmark = pytest.mark.gl


@pytest.fixture
def scene(tmp_path):
    return make_bar(tmp_path / "s", seconds=1.0)


@pytest.fixture
def frames(scene, tmp_path):
    """The PNG frames over a transparent background: (40, 120, 4) uint8 each, 11 of them."""
    assert main(["animate", scene, "-o", str(tmp_path / "ref") + "/", "--background", "transparent"]) == 0
    out = pngs(tmp_path / "ref")
    assert len(out) == 11 and out[0][0, 0, 3] == 0 and out[0][20, 60, 3] == 255
    return out


def webm_frames(path):
    """Decode with the libvpx-vp9 decoder (FFmpeg's own vp9 decoder drops the alpha plane)."""
    import av

    with av.open(path) as box:
        st = box.streams.video[0]
        assert st.codec_context.name == "vp9" and st.metadata.get("alpha_mode") == "1"
        dec = av.CodecContext.create("libvpx-vp9", "r")
        out = []
        for pkt in box.demux(st):
            for f in dec.decode(pkt):  # (the last, empty packet flushes the decoder)
                assert f.format.name == "yuva420p"
                out.append(f.to_ndarray(format="rgba"))
    return out


def test_webm_keeps_alpha(scene, frames, tmp_path):
    assert main(["animate", scene, "-o", str(tmp_path / "a.webm"), "--background", "transparent"]) == 0
    got = webm_frames(str(tmp_path / "a.webm"))
    assert len(got) == 11
    for have, want in zip(got, frames):
        assert have.shape == want.shape
        clear, solid = want[..., 3] == 0, want[..., 3] == 255
        assert clear.any() and solid.any()
        assert np.mean(have[..., 3][clear] < 16) > 0.98  # see-through where nothing is drawn
        assert np.mean(have[..., 3][solid] > 239) > 0.98
        diff = np.abs(have[..., :3].astype(int) - want[..., :3])[solid]
        assert diff.mean() < 8  # lossy, but the same picture


def test_webm_over_a_colour_is_opaque(scene, tmp_path):
    assert main(["animate", scene, "-o", str(tmp_path / "a.webm"), "--background", "#2040c0"]) == 0
    got = webm_frames(str(tmp_path / "a.webm"))
    assert len(got) == 11 and min(int(f[..., 3].min()) for f in got) >= 250
    assert np.abs(got[0][2, 2, :3].astype(int) - (0x20, 0x40, 0xC0)).max() <= 6


@pytest.mark.parametrize("fps", [10, 24, 12.5])
def test_apng_durations_and_pixels(scene, frames, tmp_path, fps):
    out = tmp_path / "a.apng"
    assert main(["animate", scene, "-o", str(out), "--background", "transparent", "--fps", str(fps)]) == 0
    with Image.open(out) as im:
        assert im.format == "PNG" and im.info.get("loop") == 0 and im.n_frames == int(fps) + 1
        durations = []
        for k in range(im.n_frames):
            im.seek(k)
            durations.append(im.info["duration"])
            if fps == 10:  # the same times as the reference frames: lossless
                assert np.array_equal(np.array(im.convert("RGBA")), frames[k])
    assert durations == pytest.approx([1000 / fps] * len(durations), abs=1e-6)


def test_sprite_sheet_atlas_matches_the_frames(scene, frames, tmp_path):
    out = tmp_path / "sheet.png"
    assert main(["animate", scene, "-o", str(out), "--background", "transparent"]) == 0
    atlas = json.loads((tmp_path / "sheet.json").read_text())
    sheet = np.array(Image.open(out))
    meta = atlas["meta"]
    assert meta["image"] == "sheet.png" and meta["format"] == "RGBA8888" and meta["scale"] == "1"
    assert (meta["size"]["w"], meta["size"]["h"]) == (sheet.shape[1], sheet.shape[0])
    names = sorted(atlas["frames"])
    assert names == [f"frame_{i:05d}.png" for i in range(11)] == atlas["animations"]["animation"]
    boxes = set()
    for name, want in zip(names, frames):
        e = atlas["frames"][name]
        r = e["frame"]
        assert e["rotated"] is False and e["trimmed"] is False
        assert e["sourceSize"] == {"w": 120, "h": 40} and e["spriteSourceSize"] == {"x": 0, "y": 0, "w": 120, "h": 40}
        assert np.array_equal(sheet[r["y"]:r["y"] + r["h"], r["x"]:r["x"] + r["w"]], want)
        boxes.add((r["x"], r["y"]))
    assert len(boxes) == 11  # no two frames share a place
    w, h = meta["size"]["w"], meta["size"]["h"]
    assert w % 120 == 0 and h % 40 == 0 and (w // 120) * (h // 40) >= 11
    assert 0.25 <= w / h <= 4  # near square


def test_sprite_sheet_too_big_is_refused(scene, tmp_path, capsys):
    out = tmp_path / "big.png"
    assert main(["animate", scene, "-o", str(out), "--size", "4000x4000"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("puppet: error:") and "8192x8192" in err and "\n" not in err
    assert sorted(os.listdir(tmp_path)) == ["s"]


def test_mp4_frames_and_rate(scene, frames, tmp_path):
    import av

    assert main(["animate", scene, "-o", str(tmp_path / "a.mp4"), "--fps", "24"]) == 0
    with av.open(str(tmp_path / "a.mp4")) as box:
        st = box.streams.video[0]
        got = [f.to_ndarray(format="rgb24") for f in box.decode(st)]
        assert st.average_rate == 24 and st.codec_context.name == "h264"
    assert len(got) == 25 and got[0].shape == (40, 120, 3)
    assert np.abs(got[0][2, 2].astype(int) - 255).max() <= 4  # the scene's white background


@pytest.mark.parametrize("fps", [24, 25, 30, 12])
def test_gif_plays_at_fps_on_average(tmp_path, fps):
    """Over any second, the stored delays (whole 1/100 s) average 1/fps within 1 ms."""
    scene = make_bar(tmp_path / "s", seconds=2.0)
    out = tmp_path / "a.gif"
    assert main(["animate", scene, "-o", str(out), "--fps", str(fps)]) == 0
    with Image.open(out) as im:
        ms = []
        for k in range(im.n_frames):
            im.seek(k)
            ms.append(im.info["duration"])
    assert len(ms) == 2 * fps + 1  # every frame differs (none merged)
    assert len(set(ms)) <= 2 and min(ms) >= 10 * int(100 / fps)
    for start in range(len(ms) - fps + 1):
        assert abs(sum(ms[start:start + fps]) / fps - 1000 / fps) <= 1.0


def test_transparent_gif(scene, frames, tmp_path):
    out = tmp_path / "t.gif"
    assert main(["animate", scene, "-o", str(out), "--background", "transparent"]) == 0
    with Image.open(out) as im:
        assert im.n_frames == 11
        for k, want in enumerate(frames):
            im.seek(k)
            a = np.array(im.convert("RGBA"))
            assert np.array_equal(a[..., 3] > 0, want[..., 3] >= 128), k  # bar moved: old pixels cleared
            solid = want[..., 3] == 255
            assert np.abs(a[..., :3][solid].astype(int) - want[..., :3][solid]).max() <= 24


@pytest.mark.parametrize("text,corner", [("#102030", (16, 32, 48, 255)), ("#10203080", (16, 32, 48, 128)),
                                         ("red", (255, 0, 0, 255)), ("transparent", (0, 0, 0, 0)),
                                         ("#0f0", (0, 255, 0, 255))])
def test_background_colours(scene, tmp_path, text, corner):
    assert main(["animate", scene, "-o", str(tmp_path / "f") + "/", "--background", text]) == 0
    f = np.array(Image.open(tmp_path / "f" / "frame_00000.png"))
    got = f[1, 1].astype(int)
    if corner[3] == 0:
        assert got[3] == 0
    else:
        assert np.abs(got - corner).max() <= 1, got
    assert tuple(f[20, 60, :3]) == (200, 40, 40) and f[20, 60, 3] == 255  # the bar itself


def test_default_background_is_the_scenes(scene, tmp_path):
    assert main(["animate", scene, "-o", str(tmp_path / "f") + "/"]) == 0
    assert tuple(np.array(Image.open(tmp_path / "f" / "frame_00000.png"))[1, 1]) == (255, 255, 255, 255)


@pytest.mark.parametrize("args,say", [
    (["-o", "a.mp4", "--background", "transparent"], "MP4"),
    (["-o", "a.mp4", "--background", "#ff000080"], "MP4"),
    (["-o", "a.gif", "--background", "#12345"], "is not a colour"),
    (["-o", "a.gif", "--background", "chartreusy"], "is not a colour"),
    (["-o", "f/", "--background", ""], "is not a colour"),
    (["-o", "a.webp"], ".webm, .apng"),
])
def test_bad_values_exit_2_with_one_line(scene, tmp_path, capsys, args, say, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["animate", scene, *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("puppet: error:") and err.count("\n") == 1 and say in err, err
    assert sorted(os.listdir(tmp_path)) == ["s"]


def test_sheet_atlas_never_overwrites_the_scene(tmp_path, capsys):
    """``puppet animate s/scene.json -o s/scene.png``: the atlas would be the scene file."""
    scene = make_bar(tmp_path / "s")
    before = open(scene).read()
    assert main(["animate", scene, "-o", os.path.splitext(scene)[0] + ".png"]) == 2
    err = capsys.readouterr().err
    assert "it is a file the scene reads" in err and err.count("\n") == 1
    assert open(scene).read() == before and not os.path.exists(os.path.splitext(scene)[0] + ".png")


def test_odd_sizes_keep_their_size_where_the_format_allows(scene, tmp_path):
    """WebM, APNG and sheets keep 121x41; H.264 (4:2:0) is padded to 122x42."""
    import av

    for name in ("a.webm", "a.apng", "a.mp4"):
        assert main(["animate", scene, "-o", str(tmp_path / name), "--size", "121x41", "--to", "0.2"]) == 0
    assert webm_frames(str(tmp_path / "a.webm"))[0].shape == (41, 121, 4)
    with Image.open(tmp_path / "a.apng") as im:
        assert im.size == (121, 41) and im.n_frames == 3
    with av.open(str(tmp_path / "a.mp4")) as box:
        assert [f.to_ndarray(format="rgb24").shape for f in box.decode(video=0)] == [(42, 122, 3)] * 3
