"""The automatic map on characters drawn in profile whose pin names say nothing (the
runner and the T-rex with their pins renamed p0..pN): parts found by place, hands to
hands and feet to feet on both sides, the head to the head, a tail to the root; and the
named and front-facing cases mapped as before."""
from __future__ import annotations

import hashlib
import json
import os
import random

import numpy as np
import pytest

from puppet.cli import main
from puppet.motion.bvh import read_bvh
from puppet.motion.names import part_and_side
from puppet.motion.project import character_facing, parts_by_place
from puppet.motion.retarget import retarget
from tests.conftest import ASSETS, SCENES

CLIPS = ("walk", "wave", "jumping_jacks", "dance")
#: What each pin of the two profile characters is (hand-checked against the drawings).
PARTS = {
    "runner": {"head": "head", "fist": "hand", "back_hand": "hand", "front_foot": "foot", "back_foot": "foot",
               "chest": "chest", "hip": "hip"},
    "trex-layers": {"hip": "hip", "chest": "chest", "tail_tip": "tail", "jaw": "head", "snout": "head",
                    "hand_front": "hand", "hand_back": "hand", "foot_left": "foot", "foot_right": "foot"},
}


def _pins(scene: str) -> dict[str, np.ndarray]:
    doc = json.load(open(os.path.join(SCENES, f"{scene}.json")))
    return {p["name"]: np.asarray(p["at"], np.float64) for p in doc["pins"] if p.get("kind") != "starch"}


def _clips():
    return {c: read_bvh(os.path.join(ASSETS, "motion", f"{c}.bvh")) for c in CLIPS}


def test_parts_by_place_on_the_drawn_characters():
    """The parts found from the pins' places alone are what their names say (the runner, the
    T-rex; the horse's four hooves are feet, its back the hip); the front-facing character's
    hands, feet, head, hip and chest are found too, its shoulders left unknown; fewer than
    four pins, or a flat row, get nothing."""
    for scene, want in PARTS.items():
        assert parts_by_place(_pins(scene)) == want
    assert parts_by_place(_pins("horse")) == {"front_hoof_a": "foot", "front_hoof_b": "foot", "hind_hoof_a": "foot",
                                              "hind_hoof_b": "foot", "head": "head", "tail": "tail", "back": "hip"}
    got = parts_by_place(_pins("character"))
    assert got == {"hand_l": "hand", "hand_r": "hand", "foot_l": "foot", "foot_r": "foot", "hip": "hip",
                   "chest": "chest", "head": "head", "shoulder_l": None, "shoulder_r": None}
    assert set(parts_by_place({"a": (0, 0), "b": (0, 9), "c": (5, 5)}).values()) == {None}
    assert set(parts_by_place({f"p{i}": (i, 3.0) for i in range(5)}).values()) == {None}


def test_the_facing_of_renamed_characters_comes_from_their_places():
    """Renamed, the runner and the T-rex are still in profile facing the screen's left (right
    when mirrored); the renamed front-facing character is not in profile, (-1, False) as before."""
    for scene in PARTS:
        pins = _pins(scene)
        renamed = {f"p{i}": v for i, v in enumerate(pins.values())}
        mirrored = {n: np.array([1000.0 - v[0], v[1]]) for n, v in renamed.items()}
        assert character_facing(pins) == character_facing(renamed) == (-1, True)
        assert character_facing(mirrored) == (1, True)
    front = _pins("character")
    assert character_facing({f"p{i}": v for i, v in enumerate(front.values())}) == (-1, False)


def _variants(pins: dict[str, np.ndarray]):
    """``(renamed pins, {new name: old name})``: renamed p0..pN as drawn, mirrored, shuffled,
    and scaled and moved."""
    items = list(pins.items())
    shuffled = items[:]
    random.Random(1).shuffle(shuffled)
    for how, rows in (("drawn", items), ("mirrored", items), ("shuffled", shuffled), ("scaled", items)):
        out = {}
        for i, (_, v) in enumerate(rows):
            out[f"p{i}"] = {"mirrored": np.array([1000.0 - v[0], v[1]]), "scaled": 0.37 * v + [11.0, -5.0]}.get(how, v)
        yield how, out, {f"p{i}": n for i, (n, _) in enumerate(rows)}


@pytest.mark.parametrize("scene", list(PARTS))
def test_the_automatic_map_on_renamed_characters_in_profile(scene):
    """Each clip, pins renamed (as drawn, mirrored, shuffled, scaled): seen from the side; the
    two hands on two hand joints of both sides, the two feet on two foot joints of both sides,
    the head on the head, the hip on the root (the T-rex's tail too); of each pair the pin
    to the screen's left follows the joint to the left in the first frame. The map is the
    same whatever the variant."""
    pins, clips = _pins(scene), _clips()
    for clip, m in clips.items():
        index = {n: i for i, n in enumerate(m.names)}
        P0 = m.positions(slice(0, 1))[0]
        maps = []
        for how, given, back in _variants(pins):
            r = retarget(m, given)
            assert r.projection == "sagittal", (clip, how)
            got = {back[p]: j for p, j in r.map.items()}
            maps.append(got)
            x = {p: float(given[q][0]) for q, p in back.items()}
            qx = {j: float(P0[index[j]] @ r.plane[0]) for j in got.values()}
            for part in ("hand", "foot"):
                two = [p for p, w in PARTS[scene].items() if w == part]
                assert [part_and_side(got[p])[0] for p in two] == [part, part], (clip, how, got)
                assert {part_and_side(got[p])[1] for p in two} == {"left", "right"}, (clip, how, got)
                a, b = sorted(two, key=x.get)
                assert qx[got[a]] <= qx[got[b]], (clip, how, part, got)
            heads = [p for p, w in PARTS[scene].items() if w == "head"]
            assert "Head" in {got[p] for p in heads}, (clip, how, got)
            root = m.names[next(i for i, j in enumerate(m.joints) if j.parent < 0)]
            assert got["hip"] == root and got.get("tail_tip", root) == root, (clip, how, got)
        assert all(g == maps[0] for g in maps), (clip, maps)


def test_named_and_front_facing_maps_are_as_before():
    """The maps (and projections) of the named character, runner and T-rex and of the renamed
    front-facing character, on every clip, auto and sagittal: the digest made before parts were
    found by place."""
    clips, rows = _clips(), []
    character = _pins("character")
    cases = {"character/named": character, "runner/named": _pins("runner"), "trex-layers/named": _pins("trex-layers"),
             "character/renamed": {f"p{i}": v for i, v in enumerate(character.values())}}
    for case, given in cases.items():
        for clip, m in clips.items():
            for proj in ("auto", "sagittal"):
                r = retarget(m, given, projection=proj)
                rows.append([f"{case}/{clip}/{proj}", r.projection, r.map])
    rows.sort(key=lambda row: row[0])
    assert hashlib.sha256(json.dumps(rows, sort_keys=True).encode()).hexdigest()[:16] == "303716e76c24f00e"


def test_the_renamed_horse_drives_its_hooves_with_feet_and_toes():
    """Four hooves found at the bottom: each follows a foot or toe joint of its own; the head
    the head, the tail and the back the root (or the spine), on every clip."""
    pins, clips = _pins("horse"), _clips()
    renamed = {f"p{i}": v for i, v in enumerate(pins.values())}
    back = dict(zip(renamed, pins))
    for clip, m in clips.items():
        got = {back[p]: j for p, j in retarget(m, renamed).map.items()}
        hooves = [got[p] for p in pins if "hoof" in p]
        assert {part_and_side(j)[0] for j in hooves} <= {"foot", "toe"} and len(set(hooves)) == 4, (clip, got)
        assert got["head"] == "Head" and got["tail"] == "Hips", (clip, got)
        assert part_and_side(got["back"])[0] in ("hip", "chest"), (clip, got)


def test_layer_names_give_renamed_pins_their_sides_through_the_command(tmp_path, capsys):
    """The T-rex renamed p0..p8, its layers kept: ``puppet retarget`` reads the pins' layer
    names, so the foot on ``leftleg`` follows a left foot joint and the foot on ``rightleg``
    a right one, as the named T-rex's do, on every clip; the API given the same labels gives
    the map the command wrote (without them the sides are the clip's, as tested above)."""
    doc = json.load(open(os.path.join(SCENES, "trex-layers.json")))
    names = {p["name"]: f"p{i}" for i, p in enumerate(doc["pins"])}
    for p in doc["pins"]:
        p["name"] = names[p["name"]]
    for layer in doc["layers"]:
        layer["image"] = os.path.normpath(os.path.join(SCENES, layer["image"]))
    doc.pop("poses"), doc.pop("animation")
    scene, out = tmp_path / "trex-renamed.json", tmp_path / "out.json"
    scene.write_text(json.dumps(doc))
    clip = os.path.join(ASSETS, "motion", "walk.bvh")
    assert main(["retarget", str(scene), clip, "-o", str(out), "--end", "1"]) == 0
    capsys.readouterr()
    got = json.loads((tmp_path / "out.map.json").read_text())
    assert part_and_side(got[names["foot_left"]]) == ("foot", "left")
    assert part_and_side(got[names["foot_right"]]) == ("foot", "right")
    assert {part_and_side(got[names[h]]) for h in ("hand_front", "hand_back")} == {("hand", "left"), ("hand", "right")}
    pins = {p["name"]: np.asarray(p["at"], np.float64) for p in doc["pins"]}
    labels = {p["name"]: p["layer"] for p in doc["pins"]}
    assert retarget(read_bvh(clip), pins, labels=labels, end=1.0).map == got
    for m in _clips().values():
        r = retarget(m, pins, labels=labels)
        assert part_and_side(r.map[names["foot_left"]]) == ("foot", "left"), r.map
        assert part_and_side(r.map[names["foot_right"]]) == ("foot", "right"), r.map
