"""Retargeting the bundled clips onto the bundled characters: the automatic map (named and
renamed pins), the projection, the scale, feet held while down, keys within 0.5 px, and
the written scene's pins on their joints' paths when played through the public API."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import puppet
from puppet.anim.keys import Key, span_error
from puppet.cli import main
from puppet.motion.bvh import read_bvh
from puppet.motion.names import part_and_side
from puppet.motion.project import axes_of
from puppet.motion.retarget import TOLERANCE, animation, retarget
from tests.conftest import ASSETS, SCENES

MOTION = os.path.join(ASSETS, "motion")
CLIPS = ("walk", "wave", "jumping_jacks", "dance")


def _clip(name: str):
    return read_bvh(os.path.join(MOTION, f"{name}.bvh"))


def _pins(scene: str) -> dict[str, np.ndarray]:
    doc = json.load(open(os.path.join(SCENES, f"{scene}.json")))
    return {p["name"]: np.asarray(p["at"], np.float64) for p in doc["pins"] if p.get("kind") != "starch"}


@pytest.mark.parametrize("name, part, side", [
    ("LeftHand", "hand", "left"), ("mixamorig:LeftHand", "hand", "left"), ("lhand", "hand", "left"),
    ("hand_l", "hand", "left"), ("left_hand", "hand", "left"), ("L_Hand", "hand", "left"), ("hand.R", "hand", "right"),
    ("lfemur", "thigh", "left"), ("ltibia", "knee", "left"), ("rfoot", "foot", "right"), ("thorax", "chest", None),
    ("LeftHip", "thigh", "left"), ("Hips", "hip", None), ("LeftUpLeg", "thigh", "left"), ("LeftLeg", "knee", "left"),
    ("LeftForeArm", "elbow", "left"), ("LeftArm", "shoulder", "left"), ("LeftHandIndex1", "finger", "left"),
    ("RightToeBase", "toe", "right"), ("lowerback", "chest", None), ("foot_left", "foot", "left"),
    ("back_foot", "foot", None), ("hand_back", "hand", None), ("front_hoof_a", "foot", None), ("snout", "head", None),
    ("tail_tip", "tail", None), ("p3", None, None), ("RThumb", "finger", "right"), ("lowerneck", "neck", None),
])
def test_names_say_a_part_and_a_side(name, part, side):
    assert part_and_side(name) == (part, side)


def _side_of(joint: str) -> str | None:
    return part_and_side(joint)[1]


def test_the_automatic_map_on_the_front_facing_character_named_and_renamed():
    """Hands to hands, feet to feet, on every clip (three skeleton conventions), and with the
    pins renamed p0..p8 too; the hand and foot drawn on the screen's right follow the
    performer's left (a character facing the viewer), so each side is one side of the body."""
    pins = _pins("character")
    renamed = {f"p{i}": v for i, v in enumerate(pins.values())}
    back = dict(zip(renamed, pins))
    for clip in CLIPS:
        m = _clip(clip)
        for given in (pins, renamed):
            got = {back.get(p, p): j for p, j in retarget(m, given).map.items()}
            for pin in ("hand_l", "hand_r", "foot_l", "foot_r"):
                want = "hand" if pin.startswith("hand") else "foot"
                assert part_and_side(got[pin])[0] == want, (clip, given is pins, got)
                assert _side_of(got[pin]) == ("left" if pin.endswith("_r") else "right"), (clip, got)
            assert part_and_side(got["head"])[0] == "head" and part_and_side(got["hip"])[0] == "hip", (clip, got)
            assert len(set(got.values())) == len(got)


@pytest.mark.parametrize("scene, hands, feet", [
    ("trex-layers", ("hand_front", "hand_back"), ("foot_left", "foot_right")),
    ("runner", ("fist", "back_hand"), ("front_foot", "back_foot")),
])
def test_the_automatic_map_on_characters_in_profile(scene, hands, feet):
    """Seen from the side (sagittal, chosen by the character's facing): two hands on the two
    hands of the skeleton, two feet on its two feet, the head on the head; a named side is kept."""
    pins = _pins(scene)
    for clip in CLIPS:
        r = retarget(_clip(clip), pins)
        assert r.projection == "sagittal"
        for group, part in ((hands, "hand"), (feet, "foot")):
            parts = [part_and_side(r.map[p]) for p in group]
            assert all(p == part for p, _ in parts), (clip, r.map)
            assert {s for _, s in parts} == {"left", "right"}, (clip, r.map)
        assert "head" in {part_and_side(r.map[p])[0] for p in pins if part_and_side(p)[0] == "head"}
        if scene == "trex-layers":
            assert _side_of(r.map["foot_left"]) == "left" and r.map["tail_tip"] == r.map["hip"] == "Hips"


def test_projection_axes_and_scale_by_leg_length():
    """The CMU clip is Y up with the performer's left along +x: frontal is ([1, 0, 0], [0, -1, 0]);
    the scale is the character's hip-to-foot over the motion's; the pca plane holds more of
    the motion's variance than the frontal and sagittal planes."""
    m, pins = _clip("jumping_jacks"), _pins("character")
    r = retarget(m, pins)
    assert r.projection == "frontal"
    np.testing.assert_allclose(r.plane, [[1, 0, 0], [0, -1, 0]], atol=0.05)
    P0 = m.positions(slice(0, 1))[0]
    i = {n: k for k, n in enumerate(m.names)}
    legs = [(np.linalg.norm(pins[f] - pins["hip"]), np.linalg.norm(P0[i[r.map[f]]] - P0[i["Hips"]]))
            for f in ("foot_l", "foot_r")]
    assert r.scale == pytest.approx(np.mean([c for c, _ in legs]) / np.mean([d for _, d in legs]))
    for clip, up in zip(CLIPS, ([0, 0, 1], [0, 0, 1], [0, 1, 0], [0, 1, 0])):  # AnimatedDrawings' own are Z up
        m = _clip(clip)
        P = m.positions()
        axes = axes_of(m.names, P)
        np.testing.assert_array_equal(axes.up, up)
        np.testing.assert_allclose([axes.left @ axes.up, axes.forward @ axes.up, np.linalg.norm(axes.left)], [0, 0, 1],
                                   atol=1e-12)
        X = (P - P[:, :1]).reshape(-1, 3)
        X = X - X.mean(axis=0)
        held = {k: float(((X @ retarget(m, pins, projection=k).plane.T) ** 2).sum()) for k in ("pca", "frontal", "sagittal")}
        assert held["pca"] >= max(held["frontal"], held["sagittal"]) * (1 - 1e-9), (clip, held)
        pca = retarget(m, pins, projection="pca").plane
        np.testing.assert_allclose(pca @ pca.T, np.eye(2), atol=1e-9)


def test_in_place_keeps_the_hips_over_their_first_place():
    m, pins = _clip("walk"), _pins("trex-layers")
    moving, still = retarget(m, pins), retarget(m, pins, in_place=True)
    assert np.ptp(moving.targets["hip"][:, 0]) > 100 > 4 * np.ptp(still.targets["hip"][:, 0])
    assert not still.down  # the ground moves under the feet: none is held


def test_keys_reproduce_every_frame_within_half_a_pixel_and_feet_down_stay_still():
    m, pins = _clip("walk"), _pins("character")
    r = retarget(m, pins)
    anim = animation(r)
    names = list(r.targets)
    F = np.stack([r.targets[n] for n in names], axis=1)
    frames = [int(np.flatnonzero(np.isclose(r.times, k["time"], atol=1e-6))[0]) for k in anim["keys"]]
    assert len(frames) < len(r.times) and frames[0] == 0 and frames[-1] == len(r.times) - 1
    assert span_error(F, r.times, [Key(f) for f in frames]) <= TOLERANCE
    assert anim["inbetween"] == "linear" and all(set(k["pins"]) == set(names) for k in anim["keys"])
    assert set(r.down) == {"foot_l", "foot_r"}
    for pin, down in r.down.items():
        assert 0.3 < down.mean() < 1  # a walk: each foot down most of the time, not always
        d = np.diff(np.concatenate([[0], down.astype(int), [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            assert np.ptp(r.targets[pin][a:b], axis=0).max() == 0.0  # held exactly
        # lifted off: back on the free path within the blend, without a jump on the way
        step = np.linalg.norm(np.diff(r.targets[pin], axis=0), axis=1)
        assert step.max() <= 1.5 * np.linalg.norm(np.diff(r.free[pin], axis=0), axis=1).max() + 1e-9
        assert np.abs(r.targets[pin][~down] - r.free[pin][~down]).max() < np.abs(r.free[pin] - r.free[pin][0]).max()


def test_the_written_scene_plays_the_joint_paths_through_the_public_api(tmp_path, capsys):
    """``puppet retarget`` then ``load_scene(OUT).layers(time=t)``: every pin within 2 px of its
    joint's scaled projected path (at + s (q(t) - q(0)), computed here from the clip), feet
    that are down within 2 px of where they touched down; OUT.map.json read back with --map
    gives the same scene."""
    scene, clip = os.path.join(SCENES, "character.json"), os.path.join(MOTION, "jumping_jacks.bvh")
    out = tmp_path / "jj.json"
    assert main(["retarget", scene, clip, "-o", str(out), "--end", "2"]) == 0
    assert "onto 9 pins" in capsys.readouterr().out
    mapping = json.loads((tmp_path / "jj.map.json").read_text())
    m, pins = _clip("jumping_jacks"), _pins("character")
    r = retarget(m, pins, end=2.0)
    assert r.map == mapping
    P = m.positions(slice(0, len(r.times)))
    i = {n: k for k, n in enumerate(m.names)}
    played = puppet.load_scene(str(out))
    worst, held = 0.0, {}
    for f in (0, 3, 9, 22, 31, 47, len(r.times) - 1):
        for L in played.layers(time=float(r.times[f])):
            for pin, v in L.pins.items():
                if pin not in mapping:
                    continue
                got = L.deformed[v]
                if pin in r.down:  # a foot: on its target (held while down, then blended back)
                    assert np.linalg.norm(got - r.targets[pin][f]) <= 2.0
                    if r.down[pin][f]:  # one contact: the down frames since the last lift-off
                        run = int(np.sum(np.diff(r.down[pin][:f + 1].astype(int)) == 1))
                        held.setdefault((pin, run), []).append(got)
                    continue
                j = i[mapping[pin]]
                want = pins[pin] + r.scale * ((P[f, j] - P[0, j]) @ r.plane.T)
                worst = max(worst, float(np.linalg.norm(got - want)))
    assert worst <= 2.0
    assert any(len(v) > 1 for v in held.values())
    assert all(np.ptp(np.array(v), axis=0).max() <= 2.0 for v in held.values()), held
    again = tmp_path / "again.json"
    assert main(["retarget", scene, clip, "-o", str(again), "--end", "2", "--map", str(tmp_path / "jj.map.json")]) == 0
    assert json.loads(again.read_text())["animation"] == json.loads(out.read_text())["animation"]
    # corrected in place and passed back under the same -o: the scene is written again, the map left as given
    mapping["shoulder_l"] = "RightElbow"
    (tmp_path / "jj.map.json").write_text(json.dumps(mapping))
    assert main(["retarget", scene, clip, "-o", str(out), "--end", "2", "--map", str(tmp_path / "jj.map.json")]) == 0
    assert json.loads((tmp_path / "jj.map.json").read_text()) == mapping
    keys = json.loads(out.read_text())["animation"]["keys"]
    assert keys[-1]["pins"]["shoulder_l"] != json.loads(again.read_text())["animation"]["keys"][-1]["pins"]["shoulder_l"]


BAD_MAP_PIN = {"hand_l": "LeftWrist", "paw": "LeftWrist"}
BAD_MAP_JOINT = {"hand_l": "LeftPaw"}


@pytest.mark.parametrize("case, words", [
    ("bvh", "line 3: 'ROOT' expected, found 'JOINT'"),
    ("pin", "no pin named 'paw' in the scene"),
    ("joint", "hand_l: no joint named 'LeftPaw' in the motion"),
    ("range", "no frame from 9 s on (the motion has 125 frames"),
    ("output", "the output must end in .json"),
])
def test_refusals_in_one_line_with_no_output(tmp_path, capsys, case, words):
    scene, clip = os.path.join(SCENES, "character.json"), os.path.join(MOTION, "jumping_jacks.bvh")
    out = tmp_path / ("o.txt" if case == "output" else "o.json")
    args = ["retarget", scene, clip, "-o", str(out)]
    if case == "bvh":
        bad = tmp_path / "bad.bvh"
        bad.write_text("HIERARCHY\n\nJOINT x\n")
        args[2] = str(bad)
    elif case in ("pin", "joint"):
        f = tmp_path / "m.json"
        f.write_text(json.dumps(BAD_MAP_PIN if case == "pin" else BAD_MAP_JOINT))
        args += ["--map", str(f)]
    elif case == "range":
        args += ["--start", "9"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert sorted(os.listdir(tmp_path)) == sorted(p.name for p in tmp_path.iterdir() if p.suffix in (".bvh", ".json")
                                                  and p.name not in ("o.json", "o.map.json"))


def test_the_command_line_loads_no_motion_module_until_retarget_runs():
    code = ("import sys, puppet.cli; "
            "print(sorted(m for m in sys.modules if m.startswith(('numpy', 'scipy', 'puppet.motion.'))))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "['puppet.motion.command']", r.stdout + r.stderr


def test_limbs_scale_each_limb_by_its_own_length():
    """``scale="limbs"``: a T-rex hand moves with the chest's pin plus the hand's move
    about the chest's joint, scaled by the hand-chest distance on the T-rex over the
    motion's; ``body`` scales the same relative move by the one body scale."""
    m, pins = _clip("walk"), _pins("trex-layers")
    body, limbs = retarget(m, pins, in_place=True), retarget(m, pins, in_place=True, scale="limbs")
    assert limbs.map == body.map and limbs.map["chest"] == "Spine"
    i = {n: k for k, n in enumerate(m.names)}
    P = m.positions()
    for hand in ("hand_front", "hand_back"):
        h, c = i[limbs.map[hand]], i["Spine"]
        rel = (P[:, h] - P[:, c]) @ limbs.plane.T
        k = np.linalg.norm(pins[hand] - pins["chest"]) / np.linalg.norm(P[0, h] - P[0, c])
        assert k < 0.5 * body.scale  # the T-rex's arms are short
        np.testing.assert_allclose(limbs.targets[hand] - limbs.targets["chest"] - (pins[hand] - pins["chest"]),
                                   k * (rel - rel[0]), atol=1e-9)
        np.testing.assert_allclose(body.targets[hand] - body.targets["chest"] - (pins[hand] - pins["chest"]),
                                   body.scale * (rel - rel[0]), atol=1e-9)


def test_a_bad_clip_through_the_command_in_a_process_of_its_own(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 zero\n")
    out = tmp_path / "o.json"
    r = subprocess.run([sys.executable, "-m", "puppet", "retarget", os.path.join(SCENES, "character.json"), str(bad),
                        "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip() == f"puppet: error: {bad}: line 4: an OFFSET value: 'zero' is not a number"
    assert sorted(os.listdir(tmp_path)) == ["bad.bvh"]
