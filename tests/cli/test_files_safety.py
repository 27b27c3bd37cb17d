"""Issue 20 through the real CLI (a subprocess each, bounded by a timeout): a truncated or
oversized video, --tracks and the video both or neither, frame folders holding a folder or
a link named like a frame, GrabCut over the whole picture, init's implicit mask behind a
link, --background out of range, NUL bytes and /proc files as scene paths, a display
without a server. Every refusal: exit 2, one stderr line, no traceback, files unchanged."""
from __future__ import annotations

import json
import os

import av
import numpy as np
import pytest

from tests.cli.outputs_helpers import Mount, bounded, cli, make_bar, one_error_line, snapshot  # noqa: F401
from tests.conftest import ROOT
from tests.video.video_helpers import W, H, frame, video_scene, write_scene

HORSE = os.path.join(ROOT, "assets", "horse", "horse.png")


def encode(path, n, *, codec="libx264", size=(W, H), fmt=None, pix="yuv420p", options=None) -> bytes:
    with av.open(str(path), "w", format=fmt, options=options or {}) as box:
        st = box.add_stream(codec, rate=12)
        st.width, st.height, st.pix_fmt = size[0], size[1], pix
        for i in range(n):
            img = frame(i) if size == (W, H) else np.full((size[1], size[0], 3), 40 + i, np.uint8)
            for p in st.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                box.mux(p)
        for p in st.encode():
            box.mux(p)
    return open(path, "rb").read()


def decoded(path) -> int:
    with av.open(str(path)) as box:
        return sum(1 for _ in box.decode(video=0))


@pytest.mark.parametrize("kind", ["mp4", "avi"])
def test_truncated_video_writes_what_it_decoded_and_says_so(tmp_path, kind):
    full = tmp_path / f"full.{kind}"
    if kind == "mp4":  # the header first (faststart), as phones and the web write them
        data = encode(full, 24, options={"movflags": "faststart"})
    else:
        data = encode(full, 24, codec="mjpeg", pix="yuvj420p")
    (tmp_path / f"cut.{kind}").write_bytes(data[:int(len(data) * 0.9)])
    os.remove(full)
    s = write_scene(tmp_path, video_scene(f"cut.{kind}"))
    r = cli("video", s, "--pose", "wave", "-o", tmp_path / "o.mp4", "--tracks", tmp_path / "t.json", timeout=240)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    warn = [ln for ln in r.stderr.splitlines() if "warning" in ln]
    assert len(warn) == 1 and "declares 24 frames" in warn[0], r.stderr
    got = decoded(tmp_path / "o.mp4")
    assert 1 <= got < 24 and f"wrote frames 0-{got - 1} only" in warn[0]
    doc = json.loads((tmp_path / "t.json").read_text())
    assert all(len(v) == got for v in doc["joints"].values())  # no trailing nulls for frames never seen
    assert all(p is not None for v in doc["joints"].values() for p in v[:1])


def test_video_that_ends_before_the_start_frame_fails(tmp_path):
    data = encode(tmp_path / "full.mp4", 24, options={"movflags": "faststart"})
    (tmp_path / "cut.mp4").write_bytes(data[:int(len(data) * 0.9)])
    s = write_scene(tmp_path, video_scene("cut.mp4", video={"start": 23}))
    before = snapshot(tmp_path)
    line = one_error_line(cli("video", s, "--pose", "wave", "-o", tmp_path / "o.mp4", timeout=120))
    assert "cut.mp4" in line
    assert snapshot(tmp_path) == before


def test_video_frames_have_the_image_size_limit(tmp_path):
    encode(tmp_path / "wide.avi", 2, codec="mjpeg", size=(20000, 64), pix="yuvj420p")
    scene = video_scene("wide.avi")
    s = write_scene(tmp_path, scene)
    before = snapshot(tmp_path)
    for args in (["check", s], ["video", s, "--pose", "wave", "-o", tmp_path / "o.mp4"]):
        line = one_error_line(cli(*args, timeout=60))
        assert "20000x64" in line and "too large" in line
    assert snapshot(tmp_path) == before


def test_tracks_and_video_are_written_both_or_neither(tmp_path):
    from tests.video.video_helpers import write_mp4_clip

    write_mp4_clip(tmp_path / "walk.mp4", n=4)
    s = write_scene(tmp_path, video_scene("walk.mp4"))
    full = Mount(tmp_path / "full", size="64k")
    try:
        full.fill()  # the tracks' folder takes no more bytes: the tracks fail after every frame is written
        before = snapshot(tmp_path)
        line = one_error_line(cli("video", s, "--pose", "wave", "-o", tmp_path / "o.mp4",
                                  "--tracks", tmp_path / "full" / "t.json", timeout=120))
        assert "t.json" in line
        assert snapshot(tmp_path) == before  # no video, no tracks, no temporary
    finally:
        full.close()


@pytest.mark.gl
def test_frame_folder_keeps_a_folder_or_link_named_like_a_frame(tmp_path):
    s = make_bar(tmp_path / "in", seconds=0.2)
    out = tmp_path / "f"
    keep = out / "frame_00000.png"
    keep.mkdir(parents=True)
    (keep / "notes.txt").write_text("mine")
    (tmp_path / "elsewhere.png").write_bytes(b"x")
    os.symlink(tmp_path / "elsewhere.png", out / "frame_00001.png")
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", s, "-o", str(out) + "/"))
    assert "frame_00000.png" in line
    assert snapshot(tmp_path) == before
    os.rename(keep, tmp_path / "moved")
    line = one_error_line(cli("animate", s, "-o", str(out) + "/"))
    assert "frame_00001.png" in line and os.path.islink(out / "frame_00001.png")


@pytest.mark.gl
@pytest.mark.slow
def test_grabcut_over_the_whole_picture(tmp_path):
    r = cli("init", HORSE, "-o", tmp_path / "s.json", "--grabcut", "0,0,400,328")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "grabcut" in r.stdout
    scene = {"puppet": 1, "source": HORSE, "layers": [{"name": "h", "mask": {"grabcut": [-5, -5, 900, 900]}}]}
    (tmp_path / "g.json").write_text(json.dumps(scene))
    r = cli("render", tmp_path / "g.json", "-o", tmp_path / "g.png")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr


def test_init_does_not_write_its_mask_through_a_link(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "precious.png").write_bytes(b"precious")
    work = tmp_path / "work"
    work.mkdir()
    os.symlink(outside / "precious.png", work / "s-mask.png")
    before = snapshot(tmp_path)
    line = one_error_line(cli("init", HORSE, "-o", work / "s.json"))
    assert "s-mask.png" in line and "link" in line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("colour", ["rgb(300,0,0)", "hsl(400,200%,50%)", "rgb(50%,200%,0%)", "hsl(0,0%,150%)"])
def test_background_out_of_range(tmp_path, colour):
    s = make_bar(tmp_path / "in", seconds=0.2)
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", s, "-o", str(tmp_path / "f") + "/", "--background", colour))
    assert colour in line and "out of range" in line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("where", ["image", "mask", "source"])
@pytest.mark.parametrize("bad", ["x\u0000y.png",
                                 pytest.param("/proc/self/mem", marks=pytest.mark.gl)])  # refused after render made its GL context
def test_nul_bytes_and_proc_files_as_scene_paths(tmp_path, where, bad):
    s = make_bar(tmp_path / "in")
    doc = json.loads(open(s).read())
    if where == "image":
        doc["layers"][0]["image"] = bad
    elif where == "mask":
        doc["layers"][0]["mask"] = {"file": bad}
    else:
        doc["source"] = bad
        doc["layers"].append({"name": "copy", "mask": {"rect": [0, 0, 5, 5]}})
    open(s, "w").write(json.dumps(doc))
    before = snapshot(tmp_path)
    runs = (["render", s, "-o", tmp_path / "r.png"],) if where != "image" else \
        (["check", s], ["render", s, "-o", tmp_path / "r.png"], ["animate", s, "-o", tmp_path / "a.gif"])
    for args in runs:  # every command reads its paths the same way: all three on one key (the campaign: all)
        line = one_error_line(cli(*args))
        assert ("NUL" in line) if "\u0000" in bad else ("/proc/self/mem" in line)
    assert snapshot(tmp_path) == before


def test_app_on_a_display_without_a_server(tmp_path):
    s = make_bar(tmp_path)
    for display in (":87", "not-a-display"):
        env = dict(os.environ, DISPLAY=display)
        env.pop("WAYLAND_DISPLAY", None)
        import subprocess
        import sys

        r = subprocess.run([sys.executable, "-m", "puppet", "app", s], capture_output=True, text=True, timeout=60,
                           env=dict(env, PYTHONPATH=ROOT), cwd=ROOT)
        line = one_error_line(r)
        assert repr(display) in line


@pytest.mark.parametrize("text, words", [('{"\u00b2": {"hand": [1, 2]}}', (": \u00b2: ", "frame number")),
                                         ('{"' + "9" * 5000 + '": {}}', ("frame number",)),
                                         (None, ("a.json", "no such"))])
def test_bad_anchors_files(tmp_path, text, words):
    from tests.video.video_helpers import write_mp4_clip

    write_mp4_clip(tmp_path / "walk.mp4", n=4)
    s = write_scene(tmp_path, video_scene("walk.mp4"))
    if text is not None:
        (tmp_path / "a.json").write_text(text)
    before = snapshot(tmp_path)
    line = one_error_line(cli("video", s, "--pose", "wave", "-o", tmp_path / "o.mp4", "--anchors", tmp_path / "a.json"))
    for w in words:
        assert w in line, line
    assert snapshot(tmp_path) == before


def test_tracks_rename_failing_takes_the_video_back(tmp_path, monkeypatch, capsys, bounded):
    """The last step (the tracks' rename after the video's) failing leaves neither."""
    import puppet.output
    from puppet.cli import main
    from puppet.output import OutputError
    from tests.video.video_helpers import write_mp4_clip

    write_mp4_clip(tmp_path / "walk.mp4", n=3)
    s = write_scene(tmp_path, video_scene("walk.mp4"))
    before = snapshot(tmp_path)

    commit = puppet.output.Staged.commit

    def fail(self):
        if not self.path.endswith("t.json"):
            return commit(self)
        self.discard()
        raise OutputError(self.path, "Input/output error")
    monkeypatch.setattr(puppet.output.Staged, "commit", fail)
    for out in (tmp_path / "o.webm", str(tmp_path / "f") + "/"):
        assert main(["video", s, "--pose", "wave", "-o", str(out), "--tracks", str(tmp_path / "t.json")]) == 2
        assert "t.json" in capsys.readouterr().err
        assert snapshot(tmp_path) == before


def test_an_encoder_refusal_is_one_error_and_leaves_nothing(tmp_path, bounded):
    """Past the size limit's guard (the API takes any size): libx264 refuses 20000 px frames."""
    from puppet.errors import SceneError
    from puppet.video.encode import write_frames

    with pytest.raises(SceneError, match="libx264 encoder refuses 20000x64"):
        write_frames(str(tmp_path / "o.mp4"), iter([np.zeros((64, 20000, 3), np.uint8)]), 12, "mp4", (20000, 64))
    assert os.listdir(tmp_path) == []
