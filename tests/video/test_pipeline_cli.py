"""``puppet video`` end to end on small generated clips: MP4 / WebM / frame folder outputs,
the frame range, the tracks JSON in the spec form, anchors, and lost frames reported."""
from __future__ import annotations

import json
import os

import av
import numpy as np
import pytest

from puppet.cli import main
from tests.video.video_helpers import PINS, W, H, video_scene, write_folder_clip, write_mp4_clip, write_scene


def decoded(path):
    with av.open(str(path)) as box:
        return [f.to_ndarray(format="rgb24") for f in box.decode(video=0)]


@pytest.fixture(scope="module")
def mp4_scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("clip")
    write_mp4_clip(d / "walk.mp4", n=8, step=2)
    return write_scene(d, video_scene("walk.mp4"))


def test_mp4_output_and_tracks(mp4_scene, tmp_path, capsys):
    out, tracks = tmp_path / "out.mp4", tmp_path / "t.json"
    assert main(["video", mp4_scene, "--pose", "wave", "-o", str(out), "--tracks", str(tracks)]) == 0
    frames = decoded(out)
    assert len(frames) == 8 and frames[0].shape == (H, W, 3)
    doc = json.loads(tracks.read_text())
    assert set(doc) == {"fps", "size", "joints", "confidence"}
    assert doc["fps"] == pytest.approx(12.0) and doc["size"] == [W, H]
    assert set(doc["joints"]) == set(PINS) and set(doc["confidence"]) == set(PINS)
    for name, (x, y) in PINS.items():
        path = doc["joints"][name]
        assert len(path) == 8 and len(doc["confidence"][name]) == 8
        assert path[0] == [x, y]  # canvas coordinates, like the pins
        # the character moves 2 px right per frame
        assert abs(path[7][0] - (x + 14)) < 1.5 and abs(path[7][1] - y) < 1.5
    # the re-posed hand (red) is up at the pose's target on frame 0, 14 px further on frame 7
    for f, dx in ((0, 0), (7, 14)):
        r, g = frames[f][14, 111 + dx, 0], frames[f][14, 111 + dx, 1]
        assert r > 150 and g < 100, (f, frames[f][14, 111 + dx])
        assert frames[f][45, 110 + dx].min() > 180  # where the arm was: background again


def test_range_webm_and_folder(mp4_scene, tmp_path):
    webm = tmp_path / "o.webm"
    assert main(["video", mp4_scene, "--pose", "wave", "-o", str(webm), "--from", "2", "--to", "5"]) == 0
    assert len(decoded(webm)) == 4
    folder = tmp_path / "frames"
    assert main(["video", mp4_scene, "--pose", "wave", "-o", str(folder) + "/", "--to", "2"]) == 0
    assert sorted(os.listdir(folder)) == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]


def test_folder_clip_with_a_start_frame_and_anchors(tmp_path):
    write_folder_clip(tmp_path / "frames", n=5, step=1)
    # the pins are placed on frame 1 (the character 1 px right of frame 0)
    scene = video_scene("frames", video={"start": 1, "fps": 10})
    for p in scene["pins"]:
        p["at"][0] += 1
    s = write_scene(tmp_path, scene)
    anchors = tmp_path / "a.json"
    anchors.write_text(json.dumps({"3": {"hand": [127.5, 45.5]}}))
    tracks = tmp_path / "t.json"
    assert main(["video", s, "--pose", "wave", "-o", str(tmp_path / "o.mp4"), "--tracks", str(tracks),
                 "--anchors", str(anchors)]) == 0
    doc = json.loads(tracks.read_text())
    assert doc["fps"] == 10 and len(doc["joints"]["hand"]) == 4  # frames 1..4
    assert doc["joints"]["hand"][2] == [127.5, 45.5] and doc["confidence"]["hand"][2] == 1.0
    assert len(decoded(tmp_path / "o.mp4")) == 4


class _LosesFrames:
    """A tracker stand-in that loses frames 2 and 3 (holding the skeleton), to check the report."""

    def __init__(self, first, joints, mask=None):
        self.j = dict(joints)
        self.n = 0

    def step(self, frame, mask=None):
        from puppet.video.track import TrackStep

        self.n += 1
        lost = self.n in (2, 3)
        return TrackStep(self.j, {k: 0.0 if lost else 1.0 for k in self.j}, lost, "test" if lost else "")


def test_lost_frames_are_reported_and_null_in_tracks(mp4_scene, tmp_path, capsys, monkeypatch):
    import puppet.video.track as track

    monkeypatch.setattr(track, "Tracker", _LosesFrames)
    tracks = tmp_path / "t.json"
    assert main(["video", mp4_scene, "--pose", "wave", "-o", str(tmp_path / "o.mp4"), "--tracks", str(tracks)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["puppet: tracking lost on 2 of 8 frames: 2-3 (the skeleton was held; "
                   "re-place it there with --anchors)"]
    doc = json.loads(tracks.read_text())
    assert doc["joints"]["hand"][2] is None and doc["joints"]["hand"][4] is not None
    assert len(decoded(tmp_path / "o.mp4")) == 8
