"""Pose keys with pin overrides ("pose plus pin overrides"): the file form, the per-pin
tracks, the CLI, older scenes unchanged, and recording over pose keys that keeps them."""
import copy
import json
import os

import numpy as np
import pytest
from PIL import Image

import puppet
from puppet.errors import SceneError
from tests.cli.outputs_helpers import cli, one_error_line
from tests.conftest import SCENES, bar_image

L0, M0, R0 = [15.0, 20.0], [60.0, 20.0], [105.0, 20.0]
ORDER = ("left", "mid", "right")


def scene(keys, **anim) -> dict:
    """A bar with three pins and two poses."""
    return {"puppet": 1, "canvas": [120, 40], "background": [255, 255, 255, 255],
            "layers": [{"name": "bar", "image": "bar.png"}],
            "pins": [{"name": "left", "layer": "bar", "at": L0}, {"name": "mid", "layer": "bar", "at": M0},
                     {"name": "right", "layer": "bar", "at": R0}],
            "poses": {"bend": {"right": [100, 5], "mid": [60, 15]}, "dip": {"right": [100, 35], "left": [15, 25]}},
            "animation": {"fps": 10, "keys": keys, **anim}}


def load(make_scene, keys, name="scene.json", **anim):
    return puppet.load_scene(make_scene(scene(keys, **anim), {"bar.png": bar_image()}, name=name))


def where(sc, t):
    st = sc.state(time=t)
    return {n: st.to[i].tolist() for i, n in enumerate(ORDER)}


# -- the file form and the tracks ------------------------------------------------------------
def test_override_replaces_the_pose_target(make_scene):
    sc = load(make_scene, [{"time": 0, "pose": "rest"},
                           {"time": 1, "pose": "bend", "overrides": {"right": [90, 10]}},
                           {"time": 2, "pose": "rest"}])
    assert where(sc, 1) == {"left": L0, "mid": [60, 15], "right": [90, 10]}
    assert where(sc, 0.5)["right"] == pytest.approx([97.5, 15])  # halfway from rest to the override
    assert where(sc, 0.5)["mid"] == pytest.approx([60, 17.5])  # the pose's other pins as before
    assert sc.key_times("right") == [0, 1, 2]


def test_null_override_leaves_the_pin_out_of_the_key(make_scene):
    sc = load(make_scene, [{"time": 0, "pins": {"right": [105, 0]}},
                           {"time": 1, "pose": "dip", "overrides": {"right": None}, "ease": "smooth"},
                           {"time": 3, "pins": {"right": [105, 40]}}])
    # right passes through t = 1 on its own keys (linear, 0 -> 3 s); left and mid follow the pose
    assert where(sc, 1)["right"] == pytest.approx([105, 40 / 3])
    assert where(sc, 1)["left"] == [15, 25] and where(sc, 1)["mid"] == M0
    assert sc.key_times("right") == [0, 3] and sc.key_times("left") == [1] and sc.key_times() == [0, 1, 3]


def test_overrides_name_exterior_points_and_pins_with_angles(make_scene):
    sc = load(make_scene, [{"time": 0, "pose": "bend",
                            "overrides": {"mid": {"to": [60, 25], "angle": 30, "depth": 1}}}])
    st = sc.state(time=0)
    assert st.to[1].tolist() == [60, 25] and st.angle[1] == 30 and st.depth[1] == 1


@pytest.mark.parametrize("key, path, words", [
    ({"time": 0, "pins": {"mid": [1, 1]}, "overrides": {"mid": None}}, "animation.keys[0].overrides",
     "go with a 'pose' key"),
    ({"time": 0, "pose": "bend", "overrides": {"elbow": [1, 1]}}, "animation.keys[0].overrides.elbow",
     "no pin named"),
    ({"time": 0, "pose": "bend", "overrides": {"elbow": None}}, "animation.keys[0].overrides.elbow",
     "no pin named"),
    ({"time": 0, "pose": "bend", "overrides": {"mid": "up"}}, "animation.keys[0].overrides.mid", ""),
    ({"time": 0, "pose": "bend", "overrides": [1, 2]}, "animation.keys[0].overrides", ""),
])
def test_bad_overrides_are_refused_with_their_path(make_scene, key, path, words):
    with pytest.raises(SceneError) as e:
        load(make_scene, [key])
    assert path in str(e.value) and words in str(e.value)


def test_older_scenes_load_and_pose_exactly_as_before():
    """Every bundled animated scene (pose keys only): the per-pin tracks are the v1 ones
    (every interior pin set by every key, from its pose's table), and an empty overrides
    map on every key changes nothing."""
    from puppet.scene.time import evaluate as ev

    for f in sorted(os.listdir(SCENES)):
        path = os.path.join(SCENES, f)
        if not f.endswith(".json") or "animation" not in json.load(open(path)):
            continue
        sc = puppet.load_scene(path)
        tr = sc.tracks()
        for n, key in enumerate(sc.data.animation.keys):
            ref = ev.rest_state(sc.data, sc.built.exterior) if key.pose == "rest" else \
                ev.pose_state(sc.data, sc.built.exterior, sc.data.poses[key.pose])
            assert (tr.pin_set[n] == [p.kind == "interior" for p in sc.data.pins]).all() and tr.ext_set[n].all()
            assert np.array_equal(tr.to[n], ref.to) and np.array_equal(tr.angle[n], ref.angle)
            assert np.array_equal(tr.depth[n], ref.depth) and np.array_equal(tr.ext[n], ref.ext_to, equal_nan=True)
        raw = sc.to_dict()
        for k in raw["animation"]["keys"]:
            k["overrides"] = {}
        with_empty = puppet.Scene(raw, path)
        for t in np.linspace(0, sc.duration(), 7):
            a, b = with_empty.state(time=t), sc.state(time=t)
            assert np.array_equal(a.to, b.to) and np.array_equal(a.angle, b.angle)
            assert np.array_equal(a.depth, b.depth) and np.array_equal(a.ext_to, b.ext_to, equal_nan=True)


def test_edits_keep_overrides_in_step(make_scene):
    sc = load(make_scene, [{"time": 0, "pose": "bend", "overrides": {"mid": [50, 20], "right": None}}])
    sc.rename_pin("mid", "centre")
    assert sc.keys()[0]["overrides"] == {"centre": [50.0, 20.0], "right": None}
    sc.remove_pin("right")
    assert sc.keys()[0]["overrides"] == {"centre": [50.0, 20.0]}
    sc.set_key(1, "dip", overrides={"centre": {"to": [61, 22], "angle": 5}})
    assert sc.keys()[1] == {"time": 1.0, "pose": "dip", "overrides": {"centre": {"to": [61.0, 22.0], "angle": 5.0}}}
    with pytest.raises(SceneError, match="overrides go with a pose key"):
        sc.set_key(2, pins={"left": [1, 1]}, overrides={"left": None})


# -- recording over pose keys ----------------------------------------------------------------
POSE_KEYS = [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "bend", "ease": "smooth"},
             {"time": 2, "pose": "dip"}, {"time": 3, "pose": "rest"}]
MOTION = {0.5: {"mid": [60, 24]}, 1.0: {"mid": [62, 26]}, 1.7: {"mid": [64, 18]}, 2.5: {"mid": [58, 21]}}


def test_recording_keeps_the_pose_keys(make_scene):
    sc = load(make_scene, copy.deepcopy(POSE_KEYS))
    ts = np.linspace(0, 3, 61)
    before = [where(sc, t) for t in ts]
    doc0 = sc.to_dict()
    assert sc.record_motion(MOTION) is True
    assert [(k["time"], k.get("pose")) for k in sc.keys() if "pose" in k] == [(0, "rest"), (1, "bend"), (2, "dip"),
                                                                            (3, "rest")]
    assert sc.keys()[2]["overrides"] == {"mid": [62.0, 26.0]} and sc.keys()[4]["overrides"] == {"mid": None}
    kt, kp = np.array(sorted(MOTION)), np.array([MOTION[t]["mid"] for t in sorted(MOTION)])
    for t, was in zip(ts, before):
        now = where(sc, t)
        assert now["left"] == pytest.approx(was["left"]) and now["right"] == pytest.approx(was["right"])
        if 0.5 <= t <= 2.5:  # the recorded pin replays the recording, linear in time...
            want = [np.interp(t, kt, kp[:, 0]), np.interp(t, kt, kp[:, 1])]
            if 0.5 < t < 1.0:  # ...but for the segment ending at the bend key, with its (smooth) ease
                u = (t - 0.5) / 0.5
                want = kp[0] + u * u * (3 - 2 * u) * (kp[1] - kp[0])
            assert now["mid"] == pytest.approx(want, abs=1e-9), t
    assert sc.history.undo_stack[-1].label == "record mid 0.5-2.5 s"
    sc.undo()
    assert sc.to_dict() == doc0


def test_recording_over_pins_keys_and_a_fresh_animation(make_scene):
    sc = load(make_scene, [{"time": 0, "pins": {"mid": [60, 10], "left": [15, 22]}},
                           {"time": 1, "pins": {"mid": [60, 30]}}, {"time": 2, "pose": "bend"}])
    sc.record_motion({0.0: {"mid": [61, 20]}, 0.6: {"mid": [62, 21]}})
    keys = sc.keys()
    assert keys[0]["pins"] == {"mid": [61.0, 20.0], "left": [15.0, 22.0]}  # the other pin stays
    assert keys[1] == {"time": 0.6, "pins": {"mid": [62.0, 21.0]}}
    assert keys[2]["pins"] == {"mid": [60.0, 30.0]}  # outside the span: untouched
    fresh = load(make_scene, [{"time": 0, "pose": "rest"}], name="fresh.json")
    fresh.remove_key(0)
    assert fresh.record_motion({0.0: {"mid": [60, 21]}, 1.0: {"mid": [60, 19]}})
    assert fresh.keys() == [{"time": 0.0, "pins": {"mid": [60.0, 21.0]}}, {"time": 1.0, "pins": {"mid": [60.0, 19.0]}}]


def test_recording_keeps_a_turned_pins_angle(make_scene):
    s = scene([{"time": 0, "pose": "rest"}, {"time": 1, "pose": "bend"}])
    s["poses"]["bend"]["mid"] = {"to": [60, 15], "angle": 20}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))
    sc.record_motion({1.0: {"mid": [58, 16]}}, start=0.8, end=1.0)
    assert sc.keys()[1]["overrides"] == {"mid": {"to": [58.0, 16.0], "angle": 20.0, "depth": 0.0}}


@pytest.mark.parametrize("call, words", [
    (lambda sc: sc.record_motion({}), "nothing recorded"),
    (lambda sc: sc.record_motion({1.0: {"elbow": [1, 1]}}), "no pin or exterior point named 'elbow'"),
    (lambda sc: sc.record_motion({1.0: {"mid": [1, 1]}}, start=1.5), "must hold every recorded time"),
])
def test_bad_recordings_are_refused(make_scene, call, words):
    sc = load(make_scene, copy.deepcopy(POSE_KEYS))
    doc = sc.to_dict()
    with pytest.raises(SceneError, match=words):
        call(sc)
    assert sc.to_dict() == doc


# -- the command line ------------------------------------------------------------------------
@pytest.mark.gl
@pytest.mark.slow
def test_render_time_with_overrides_equals_the_same_motion_as_pins_keys(tmp_path):
    Image.fromarray(bar_image()).save(tmp_path / "bar.png")
    over = scene([{"time": 0, "pose": "rest"}, {"time": 1, "pose": "bend", "overrides": {"right": [90, 10]}},
                  {"time": 2, "pose": "rest"}])
    pins = scene([{"time": 0, "pins": {"left": L0, "mid": M0, "right": R0}},
                  {"time": 1, "pins": {"left": L0, "mid": [60, 15], "right": [90, 10]}},
                  {"time": 2, "pins": {"left": L0, "mid": M0, "right": R0}}])
    for name, s in (("over.json", over), ("pins.json", pins)):
        (tmp_path / name).write_text(json.dumps(s))
    for t in ("0.5", "1"):
        outs = []
        for name in ("over", "pins"):
            out = tmp_path / f"{name}-{t}.png"
            r = cli("render", tmp_path / f"{name}.json", "--time", t, "-o", out)
            assert r.returncode == 0, r.stderr
            outs.append(np.asarray(Image.open(out)))
        assert np.array_equal(*outs)
    api = puppet.load_scene(str(tmp_path / "over.json")).render(time=1.0)
    assert np.array_equal(api, np.asarray(Image.open(tmp_path / "over-1.png")))
    r = cli("mesh", tmp_path / "over.json", "--time", "1", "-o", tmp_path / "m.json")
    assert r.returncode == 0, r.stderr
    (bar,) = json.load(open(tmp_path / "m.json"))["layers"]
    assert bar["deformed"][bar["pins"]["right"]] == pytest.approx([90, 10], abs=1e-6)
    r = cli("animate", tmp_path / "over.json", "-o", str(tmp_path / "frames") + "/", "--to", "0.3")
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(tmp_path / "frames")) == [f"frame_{i:05d}.png" for i in range(4)]


@pytest.mark.gl
@pytest.mark.slow
def test_render_time_of_a_bundled_scene_is_unchanged_by_empty_overrides(tmp_path):
    src = os.path.join(SCENES, "trex-layers.json")
    raw = puppet.load_scene(src).to_dict()  # file paths absolute: the copy reads the same images
    for k in raw["animation"]["keys"]:
        k["overrides"] = {}
    (tmp_path / "empty.json").write_text(json.dumps(raw))
    for scene_file, out in ((src, tmp_path / "plain.png"), (tmp_path / "empty.json", tmp_path / "empty.png")):
        r = cli("render", scene_file, "--time", "1.3", "-o", out)
        assert r.returncode == 0, r.stderr
    plain, empty = (np.asarray(Image.open(tmp_path / f)) for f in ("plain.png", "empty.png"))
    assert np.array_equal(plain, empty)


def test_cli_reports_a_bad_override_in_one_line(tmp_path):
    Image.fromarray(bar_image()).save(tmp_path / "bar.png")
    s = scene([{"time": 0, "pose": "bend", "overrides": {"elbow": None}}])
    (tmp_path / "bad.json").write_text(json.dumps(s))
    line = one_error_line(cli("render", tmp_path / "bad.json", "--time", "0", "-o", tmp_path / "x.png"))
    assert "animation.keys[0].overrides.elbow" in line and "bad.json" in line
    assert not (tmp_path / "x.png").exists()


def test_key_pins_keeps_a_pose_key_a_pose_key(make_scene):
    sc = load(make_scene, copy.deepcopy(POSE_KEYS))
    sc.key_pins(1.0, {"mid": [61, 22]})
    assert sc.keys()[1] == {"time": 1.0, "pose": "bend", "ease": "smooth", "overrides": {"mid": [61.0, 22.0]}}
    assert where(sc, 1.0) == {"left": L0, "mid": [61, 22], "right": [100, 5]}
    sc.key_pins(1.5, {"mid": [60, 30]})
    sc.key_pins(1.5, {"left": [16, 21]})
    assert sc.keys()[2] == {"time": 1.5, "pins": {"mid": [60.0, 30.0], "left": [16.0, 21.0]}}
    assert len(sc.keys()) == 5 and len(sc.history.undo_stack) == 3
    with pytest.raises(SceneError, match="no pins to key"):
        sc.key_pins(2, {})
