"""Issue 32, the automatic rig by anatomy (``puppet init ART --pins auto --links auto``):
a tree rooted at the torso with hinges at the joints, parts painted on others glued,
pins at the torso, the shoulders and hips and the free ends, with meaningful layer names
and with ``Layer 1``, ``Layer 2``, ..."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

import puppet
from puppet.imaging.layered import ArtLayer
from puppet.scene.make.anatomy import propose_rig, role_of, side_of, words
from puppet.scene.make.art import import_art
from tests.artfiles import DRESSED_CANVAS, ROBOT_CANVAS, ROBOT_NAMES, dressed, robot, write_psd_layers
from tests.scene.test_fit_modes import distortion


def test_names_give_roles_and_sides():
    assert words("arm_L/LeftHand") == ("arm", "l", "left", "hand")
    cases = {"legs/left": ("leg", "left"), "TopHead": ("head", None), "upperarm.R": ("arm", "right"),
             "Layer 12": (None, None), "pantsLightBlue_long": ("leg", None), "mixamorig:LeftForeArm": ("arm", "left"),
             "shirt": ("torso", None), "right_leg/shoe": ("leg", "right"), "tail_tip": ("tail", None)}
    assert {n: (role_of(n), side_of(n)) for n in cases} == cases


def edges(links) -> dict[frozenset, str]:
    return {frozenset(k["layers"]): "hinge" if k.get("points") else "segment" for k in links}


#: The robot's joints: child -> parent, by index into ROBOT_NAMES.
ROBOT_TREE = {0: 6, 1: 0, 2: 1, 3: 6, 4: 3, 5: 4, 7: 6, 8: 7, 9: 6, 10: 9, 11: 10, 12: 6, 13: 12, 14: 13}


@pytest.mark.parametrize("generic", [False, True], ids=["named", "generic"])
def test_robot_hands_join_their_forearms_not_their_thighs_and_a_hand_drag_leaves_the_rest(tmp_path, generic):
    items = robot(generic)
    names = [f"Layer {k + 1}" for k in range(len(items))] if generic else ROBOT_NAMES
    art = tmp_path / "robot.psd"
    write_psd_layers(str(art), items, ROBOT_CANVAS)
    import_art(str(art), str(tmp_path / "s.json"), pins="auto", links="auto")
    doc = json.loads((tmp_path / "s.json").read_text())
    # the links: exactly the skeleton's joints, hinges; no hand-thigh link although they overlap most
    assert edges(doc["links"]) == {frozenset((names[c], names[p])): "hinge" for c, p in ROBOT_TREE.items()}
    # the pins: hip and chest on the torso, a joint where each limb meets it, one at each free end
    by_layer: dict[str, list] = {}
    for p in doc["pins"]:
        by_layer.setdefault(p["layer"], []).append(p)
    kinds = {names.index(n): sorted(p["name"].rsplit(":", 1)[1] for p in ps) for n, ps in by_layer.items()}
    assert kinds == {6: ["chest", "hip"], 0: ["joint"], 3: ["joint"], 9: ["joint"], 12: ["joint"], 7: ["joint"],
                     2: ["end"], 5: ["end"], 11: ["end"], 14: ["end"], 8: ["end"]}
    for k in (11, 14, 2, 5):  # a hand's or a foot's end: on its far side, not at a corner (well inside)
        (x, y), (ox, oy) = by_layer[names[k]][0]["at"], items[k][3]
        a = np.pad(items[k][2][..., 3] > 0, 1).astype(np.uint8)
        depth = cv2.distanceTransform(a, cv2.DIST_L2, 5)[1:-1, 1:-1]
        assert y > oy + a.shape[0] / 2 - 1 and depth[int(y - oy), int(x - ox)] >= 0.4 * depth.max()
    # a hand pin swung 150 px about the shoulder moves the legs < 3 px, the torso < 5 px; the arm keeps its shape
    hand, shoulder = (np.array(by_layer[names[k]][0]["at"]) for k in (11, 9))
    r = np.hypot(*(hand - shoulder))
    t = 2 * np.arcsin(75 / r)  # raising the arm sideways: the hand goes out and up
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    to = shoulder + rot @ (hand - shoulder)
    assert np.hypot(*(to - hand)) == pytest.approx(150)
    res = {r.name: r for r in puppet.load_scene(str(tmp_path / "s.json")).layers(
        pose={by_layer[names[11]][0]["name"]: [float(to[0]), float(to[1])]})}
    moved = {k: float(np.hypot(*(res[names[k]].deformed - res[names[k]].rest).T).max()) for k in range(15)}
    assert max(moved[k] for k in range(6)) < 3.0 and moved[6] < 5.0
    assert moved[11] > 140
    for k in (9, 10, 11):
        assert distortion(res[names[k]].rest, res[names[k]].deformed, res[names[k]].triangles) < 0.05


@pytest.mark.parametrize("generic", [False, True], ids=["named", "generic"])
def test_dressed_character_glues_what_is_painted_on_and_hinges_the_joints(generic):
    items = dressed(generic)
    layers = [ArtLayer(f"{g}/{n}" if g else n, a, off) for n, g, a, off in items]
    names = [lay.name for lay in layers]
    rig = propose_rig(layers, canvas=DRESSED_CANVAS)
    got = edges(rig.links)
    k = {n: i for i, n in enumerate(["neck", "left_leg/leg", "right_leg/leg", "left_leg/shoe", "right_leg/shoe",
                                      "left_leg/trousers", "right_leg/trousers", "waist", "shirt", "left_arm/arm",
                                      "left_arm/sleeve", "left_arm/hand", "right_arm/arm", "right_arm/sleeve",
                                      "right_arm/hand", "head", "face", "hair"])}

    def pair(a, b):
        return frozenset((names[k[a]], names[k[b]]))
    glued = {pair("left_arm/arm", "left_arm/sleeve"), pair("right_arm/arm", "right_arm/sleeve"),
             pair("left_leg/leg", "left_leg/trousers"), pair("right_leg/leg", "right_leg/trousers"),
             pair("head", "face")} | (set() if generic else {pair("hair", "head")})
    assert {p for p, kind in got.items() if kind == "segment"} == glued
    # the hinges, between parts glued into one (an arm and its sleeve move as one)
    unit = {n: n for n in names}
    for a, b in (tuple(p) for p in glued):
        unit[a] = unit[b] = min(unit[a], unit[b])

    def units(*parts):
        return frozenset(unit[names[k[n]]] for n in parts)
    hinges = {frozenset(unit[n] for n in p) for p, kind in got.items() if kind == "hinge"}
    want = {units("left_arm/sleeve", "shirt"), units("right_arm/sleeve", "shirt"),
            units("left_arm/hand", "left_arm/sleeve"), units("right_arm/hand", "right_arm/sleeve"),
            units("waist", "shirt"), units("left_leg/trousers", "waist"), units("right_leg/trousers", "waist"),
            units("left_leg/shoe", "left_leg/leg"), units("right_leg/shoe", "right_leg/leg"),
            units("neck", "shirt"), units("head", "neck")} | ({units("hair", "head")} if generic else set())
    assert hinges == want
    assert rig.roots == [names[k["shirt"]]]
    pinned = {p["layer"] for p in rig.pins}
    assert {names[k[n]] for n in ("left_arm/hand", "right_arm/hand", "left_leg/shoe", "right_leg/shoe")} <= pinned
    assert not pinned & {names[k[n]] for n in ("left_arm/arm", "right_arm/arm", "face", "left_leg/leg")}
