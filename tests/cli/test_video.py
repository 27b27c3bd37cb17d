"""``puppet video`` and ``puppet check`` on bad video scenes: exit 2, one line, nothing written."""
from __future__ import annotations

import json
import os

import pytest

from puppet.cli import main
from tests.video.video_helpers import video_scene, write_folder_clip, write_mp4_clip, write_scene


def run(capsys, args):
    rc = main(args)
    err = capsys.readouterr().err
    return rc, err.strip().splitlines()


@pytest.fixture
def clip(tmp_path):
    write_mp4_clip(tmp_path / "walk.mp4", n=4)
    return tmp_path


def one_error(rc, lines, *words):
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("puppet: error: "), lines
    for w in words:
        assert w in lines[0], (w, lines[0])


@pytest.mark.parametrize("command", ["check", "video"])
def test_bad_video_file(clip, capsys, command):
    (clip / "junk.mp4").write_bytes(b"not a video at all" * 20)
    for name, words in (("junk.mp4", ("junk.mp4", "cannot be read as a video")),
                        ("missing.mp4", ("missing.mp4", "no such file"))):
        s = write_scene(clip, video_scene(name))
        args = ["check", s] if command == "check" else ["video", s, "--pose", "wave", "-o", str(clip / "o.mp4")]
        one_error(*run(capsys, args), "source", *words)
        assert not os.path.exists(clip / "o.mp4")


@pytest.mark.parametrize("command", ["check", "video"])
def test_pin_outside_the_start_frame(clip, capsys, command):
    scene = video_scene("walk.mp4", video={"start": 2})
    scene["pins"][2]["at"] = [150.5, 100.5]
    s = write_scene(clip, scene)
    args = ["check", s] if command == "check" else ["video", s, "--pose", "wave", "-o", str(clip / "o.mp4")]
    one_error(*run(capsys, args), "pins[2].at", "'hand'", "frame 2")
    assert not os.path.exists(clip / "o.mp4")


def test_bad_requests(clip, capsys):
    s = write_scene(clip, video_scene("walk.mp4", video={"start": 1}))
    out = str(clip / "o.mp4")
    cases = [
        (["--pose", "nope", "-o", out], ("'nope'", "wave")),
        (["--pose", "wave", "-o", str(clip / "o.avi")], ("o.avi",)),
        (["--pose", "wave", "-o", out, "--from", "0"], ("--from 0", "start frame 1")),
        (["--pose", "wave", "-o", out, "--to", "9"], ("--to 9",)),
        (["--pose", "wave", "-o", out, "--tracks", str(clip / "t.txt")], ("--tracks",)),
        (["--pose", "wave", "-o", str(clip / "walk.mp4")], ("walk.mp4",)),  # would overwrite the source
    ]
    for extra, words in cases:
        one_error(*run(capsys, ["video", s, *extra]), *words)
        assert not os.path.exists(out)
    (clip / "a.json").write_text(json.dumps({"2": {"elbow": [1, 2]}}))
    one_error(*run(capsys, ["video", s, "--pose", "wave", "-o", out, "--anchors", str(clip / "a.json")]), "elbow")
    (clip / "a.json").write_text(json.dumps({"x": {}}))
    one_error(*run(capsys, ["video", s, "--pose", "wave", "-o", out, "--anchors", str(clip / "a.json")]),
              "a.json", "frame number")
    assert not os.path.exists(out)


def test_not_a_video_scene_and_bad_video_keys(tmp_path, capsys):
    write_folder_clip(tmp_path / "frames", n=2)
    still = video_scene("frames/f0.png")
    s = write_scene(tmp_path, still)
    one_error(*run(capsys, ["video", s, "--pose", "wave", "-o", str(tmp_path / "o.mp4")]), "not a video scene")
    for extra, words in (({"video": {"start": 5}}, ("video.start", "2 frames")),
                         ({"video": {"speed": 1}}, ("video.speed",)),
                         ({"canvas": [10, 10]}, ("canvas", "160x120"))):
        s = write_scene(tmp_path, video_scene("frames", **extra))
        one_error(*run(capsys, ["check", s]), *words)
    (tmp_path / "empty").mkdir()
    s = write_scene(tmp_path, video_scene("empty"))
    one_error(*run(capsys, ["check", s]), "holds no pictures")
