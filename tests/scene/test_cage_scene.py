"""Cages in the scene (issue 33): ``layers[i].cage`` read and refused by path, its vertices
posable as ``LAYER:cageN`` handles, the layer deformed by the cage map, pins driving the
cage by landmark fitting, automatic cages saved with their points, undo, the CLI; and
scenes without a cage exactly as before."""
from __future__ import annotations

import copy
import hashlib
import json
import os

import numpy as np
import pytest

import puppet
from puppet.cli import main
from puppet.deform.cage import CageMap
from puppet.errors import SceneError
from puppet.scene.format.load import load_scene_data
from tests.conftest import bar_image

SQUARE = [[20, 15], [80, 15], [80, 65], [20, 65]]
POSED = [[20, 15], [90, 10], [85, 70], [20, 65]]  # cage1 and cage2 moved


def caged(cage=None, **extra) -> dict:
    """One 50 x 40 px box (canvas x 25..75, y 20..60) in a square cage, a pose moving two handles."""
    L = {"name": "box", "image": "box.png", "offset": [10, 10], "cage": cage or {"points": SQUARE}}
    s = {"puppet": 1, "canvas": [100, 80], "background": [255, 255, 255, 255], "layers": [L],
         "poses": {"p": {"box:cage1": POSED[1], "box:cage2": POSED[2]}}}
    s.update(extra)
    return s


@pytest.fixture
def scene(make_scene):
    def make(s: dict, name: str = "scene.json") -> str:
        return make_scene(s, {"box.png": bar_image(80, 60, (15, 10, 65, 50), (200, 80, 40)),
                              "bar.png": bar_image(80, 60, (15, 10, 65, 50), (40, 80, 200))}, name=name)
    return make


def _with(s: dict, path: str, value) -> dict:
    """``s`` with the value at a dotted path (list items by number) set."""
    s = copy.deepcopy(s)
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = s
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    return s


BAD = [  # (dotted path in the scene, value, the path the error names, words of the message)
    ("layers.0.cage.points", [[20, 15], [80, 15]], r"layers\[0\]\.cage\.points", "2 points, needs at least 3"),
    ("layers.0.cage.points", [[20, 15], [80, 65], [80, 15], [20, 65]], r"layers\[0\]\.cage\.points",
     "crosses itself"),
    ("layers.0.cage.points", [[20, 15], [2e6, 15], [20, 65]], r"layers\[0\]\.cage\.points\[1\]\[0\]", "must be <="),
    ("layers.0.cage.points", [[20, 15], [float("nan"), 15], [20, 65]], r"layers\[0\]\.cage\.points\[1\]\[0\]", ""),
    ("layers.0.cage.coordinates", "cubic", r"layers\[0\]\.cage\.coordinates", "not one of"),
    ("layers.0.cage", {}, r"layers\[0\]\.cage\.points", "'points' or 'auto'"),
    ("layers.0.cage", {"auto": 2}, r"layers\[0\]\.cage\.auto", ""),
    ("layers.0.cage", {"auto": 12, "offset": -1}, r"layers\[0\]\.cage\.offset", ""),
    ("layers.0.cage", {"points": SQUARE, "offset": 3}, r"layers\[0\]\.cage\.offset", "automatic cage"),
    ("layers.0.cage", {"points": SQUARE, "shape": 1}, r"layers\[0\]\.cage\.shape", "unknown key"),
    ("layers.0.exterior", {"auto": True}, r"layers\[0\]\.exterior", "caged layer"),
    ("poses.p", {"box:cage4": [0, 0]}, r"poses\.p\.box:cage4", "cage of 4 points"),
    ("pins", [{"name": "box:cage0", "layer": "box", "at": [50, 40]}], r"pins\[0\]\.name", "reserved"),
    ("pins", [{"name": "e", "layer": "box", "at": [50, 40], "kind": "exterior"}], r"pins\[0\]\.kind", "cage"),
]


def test_a_bad_cage_is_refused_in_one_line_naming_its_path(scene, capsys):
    for where, value, path, words in BAD:
        with pytest.raises(SceneError, match=path) as e:
            load_scene_data(scene(_with(caged(), where, value)))
        assert words in str(e.value) and "\n" not in str(e.value), (where, value, str(e.value))
    two = caged()
    two["layers"].append({"name": "bar", "image": "bar.png", "offset": [10, 10]})
    two["links"] = [{"layers": ["bar", "box"], "points": [[50, 40]]}]
    with pytest.raises(SceneError, match=r"links\[0\]\.layers\[1\]: layer 'box' has a cage"):
        load_scene_data(scene(two))
    small = scene(caged({"points": [[30, 15], [80, 15], [80, 65], [30, 65]]}))  # the box starts at x = 25
    with pytest.raises(SceneError, match=r"layers\[0\]\.cage: the cage leaves \d+ of the layer's \d+ mesh vertices"):
        puppet.load_scene(small).layers("rest")
    out = small + ".mesh.json"
    assert main(["mesh", small, "-o", out]) == 2  # the CLI: exit 2, one line, no output
    err = capsys.readouterr().err.strip()
    assert "layers[0].cage" in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert not os.path.exists(out)


@pytest.mark.parametrize("kind", ["green", "mvc", "harmonic"])
def test_handles_in_a_pose_move_the_layer_as_the_cage_map_says(scene, kind):
    doc = puppet.load_scene(scene(caged({"points": SQUARE, "coordinates": kind})))
    rest = doc.layers("rest")[0]
    assert np.abs(rest.deformed - rest.rest).max() < 1e-9
    L = doc.layers("p")[0]
    want = CageMap(SQUARE, rest.rest, kind).apply(np.array(POSED, float))
    assert np.abs(L.deformed - want).max() < 1e-9
    assert L.exterior == {f"box:cage{j}": [float(x) for x in POSED[j]] for j in range(4)}  # the posed cage
    assert not np.allclose(L.deformed, rest.rest)
    # an ad-hoc pose and an animation key move the handles the same way
    assert np.array_equal(doc.layers({"box:cage1": POSED[1], "box:cage2": POSED[2]})[0].deformed, L.deformed)


def test_a_similarity_of_the_handles_moves_the_layer_by_it(scene):
    doc = puppet.load_scene(scene(caged()))
    V = doc.layers("rest")[0].rest
    a, s, t = np.radians(25.0), 1.3, np.array([7.0, -4.0])
    R = s * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    C = np.array(SQUARE, float) @ R.T + t
    L = doc.layers({f"box:cage{j}": C[j].tolist() for j in range(4)})[0]
    assert np.abs(L.deformed - (V @ R.T + t)).max() < 0.1


def test_animation_keys_pose_handles_like_pins(scene):
    s = caged(animation={"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "p"},
                                             {"time": 2, "pins": {"box:cage0": [15, 10]}}]})
    doc = puppet.load_scene(scene(s))
    p = doc.layers("p")[0].deformed
    assert np.abs(doc.layers(time=1.0)[0].deformed - p).max() < 1e-6
    assert np.abs(doc.layers(time=0.0)[0].deformed - doc.layers("rest")[0].rest).max() < 1e-6
    half = CageMap(SQUARE, doc.layers("rest")[0].rest, "green").apply((np.array(SQUARE) + np.array(POSED)) / 2.0)
    assert np.abs(doc.layers(time=0.5)[0].deformed - half).max() < 1e-6  # in between: the cages blended
    moved = doc.layers(time=2.0)[0].exterior
    assert moved["box:cage0"] == [15.0, 10.0]


PINS = [{"name": n, "layer": "box", "at": at}
        for n, at in (("tl", [30, 25]), ("tr", [70, 25]), ("br", [70, 55]), ("bl", [30, 55]))]


def test_pins_drive_the_cage_and_handles_hold(scene):
    targets = {"tl": [28, 22], "tr": [74, 27], "br": [72, 60], "bl": [31, 54]}
    octagon = [[20, 15], [50, 10], [80, 15], [85, 40], [80, 65], [50, 70], [20, 65], [15, 40]]
    s = caged({"points": octagon}, pins=PINS, poses={"fit": targets, "both": dict(targets, **{"box:cage2": [84, 12]})})
    doc = puppet.load_scene(scene(s))
    rest = doc.layers("rest")[0]
    assert np.abs(rest.deformed - rest.rest).max() < 1e-9  # pins at rest: the rest cage
    for pose in ("fit", "both"):
        L = doc.layers(pose)[0]
        for name, xy in targets.items():
            assert np.hypot(*(L.deformed[L.pins[name]] - xy)) < 0.5, (pose, name)
    assert doc.layers("both")[0].exterior["box:cage2"] == [84.0, 12.0]  # a moved handle is held exactly
    # a similarity of the pins gives that similarity of the layer
    a, k, t = np.radians(-15.0), 0.9, np.array([3.0, 5.0])
    R = k * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    L = doc.layers({p["name"]: (np.array(p["at"], float) @ R.T + t).tolist() for p in PINS})[0]
    assert np.abs(L.deformed - (rest.rest @ R.T + t)).max() < 0.5
    # handles moved and no pin: the cage is the handles, the pins ride along (held at rest,
    # they made the fit swing the other handles and a dragged green cage moved the layer 2 px)
    L = doc.layers({"box:cage3": [95, 40]})[0]
    C = np.array(octagon, float)
    C[3] = [95, 40]
    assert np.abs(L.deformed - CageMap(octagon, rest.rest, "green").apply(C)).max() < 1e-9
    assert L.exterior["box:cage2"] == [80.0, 15.0]  # the others stay at rest


def _hash(layers) -> str:
    d = hashlib.sha256()
    for L in layers:
        for a in (L.deformed, L.depth, L.triangles):
            d.update(np.ascontiguousarray(a).tobytes())
    return d.hexdigest()[:16]


def test_scenes_without_a_cage_pose_bit_identically():
    # hashes made by the code before cages (main at d91110d)
    assert _hash(puppet.load_scene("assets/scenes/dress-garment.json").layers("twirl")) == "77dc500c607817af"
    assert _hash(puppet.load_scene("assets/scenes/trex-layers.json").layers("roar")) == "2156ff6aa7c626b5"


def test_the_cli_meshes_a_caged_scene(scene, tmp_path):
    path = scene(caged())
    out = tmp_path / "mesh.json"
    assert main(["mesh", path, "--pose", "p", "-o", str(out)]) == 0
    L = json.loads(out.read_text())["layers"][0]
    want = puppet.load_scene(path).layers("p")[0].deformed
    assert np.abs(np.array(L["deformed"]) - want).max() < 1e-3


def test_an_automatic_cage_is_saved_with_its_points_and_cage_edits_undo(scene, tmp_path):
    path = scene(caged({"auto": 8, "offset": 6}, poses={"p": {"box:cage1": [60, 5]}}))
    doc = puppet.load_scene(path)
    posed = doc.layers("p")[0]
    rest = np.array([posed.exterior[f"box:cage{j}"] for j in range(len(posed.exterior))])
    assert 3 <= len(rest) <= 8
    out = tmp_path / "saved.json"
    doc.save(str(out))
    cage = json.loads(out.read_text())["layers"][0]["cage"]
    assert cage["auto"] == 8 and cage["offset"] == 6 and len(cage["points"]) == len(rest)
    assert "points" not in doc.to_dict()["layers"][0]["cage"]  # the document itself is unchanged
    again = puppet.load_scene(str(out))
    assert again.data.layers[0].cage.points is not None
    assert np.array_equal(again.layers("p")[0].deformed, posed.deformed)  # the same cage: the same pose
    # set_cage: one undo step; a cage with fewer vertices drops the handles it lacks
    square = {"points": SQUARE, "coordinates": "mvc"}
    assert doc.set_cage("box", square)
    assert doc.data.layers[0].cage.coordinates == "mvc" and doc.history.undo_stack[-1].label == "set cage of box"
    assert doc.to_dict()["poses"]["p"] == {"box:cage1": [60, 5]}  # 4 vertices: cage1 stays
    doc.undo()
    assert doc.data.layers[0].cage.auto == 8 and np.array_equal(doc.layers("p")[0].deformed, posed.deformed)
    doc.set_cage("box", None)
    assert doc.data.layers[0].cage is None and doc.to_dict()["poses"]["p"] == {}
    doc.undo()
    assert doc.data.layers[0].cage is not None
    with pytest.raises(SceneError, match=r"layers\[0\]\.cage\.points"):
        doc.set_cage("box", {"points": [[0, 0], [1, 1]]})
    assert doc.data.layers[0].cage.auto == 8  # a refused edit changes nothing
    doc.rename_layer("box", "skirt")  # its handles are renamed with it
    assert doc.to_dict()["poses"]["p"] == {"skirt:cage1": [60, 5]}


def test_handles_follow_their_vertex_when_the_cage_gains_or_loses_one(scene):
    five = [[10, 10], [50, 2], [90, 10], [90, 70], [10, 70]]
    targets = {"box:cage1": [50, -4], "box:cage3": [96, 76]}
    doc = puppet.load_scene(scene(caged({"points": five}, poses={"p": targets})))
    posed = doc.layers("p")[0].deformed
    added = np.insert(np.array(five, float), 3, [90, 40], axis=0)  # on edge 2-3: old 3, 4 become 4, 5
    assert doc.set_cage("box", {"points": added.tolist()}, vertices=[0, 1, 2, None, 3, 4])
    assert doc.to_dict()["poses"]["p"] == {"box:cage1": [50, -4], "box:cage4": [96, 76]}
    U = doc.layers("p")[0].deformed  # the same vertices pulled: nearly the same pose (another cage)
    assert np.abs(U - posed).max() < 3.0 and np.abs(U - doc.layers()[0].deformed).max() > 3.0
    # delete old vertex 1: its target is dropped, 2.. become 1..
    assert doc.set_cage("box", {"points": np.delete(added, 1, axis=0).tolist()}, vertices=[0, 2, 3, 4, 5])
    assert doc.to_dict()["poses"]["p"] == {"box:cage3": [96, 76]}
    doc.undo()
    doc.undo()
    assert doc.to_dict()["poses"]["p"] == targets
    for bad in ([0, 1, 1, 2, 3, 4], [0, 1, 2], [0, -1, 1, 2, 3, 4], [0, "a", 1, 2, 3, 4]):
        with pytest.raises(SceneError, match="set_cage: vertices must give"):
            doc.set_cage("box", {"points": added.tolist()}, vertices=bad)
    assert np.array_equal(doc.layers("p")[0].deformed, posed)  # refused: nothing changed


@pytest.mark.gl
def test_the_cli_renders_and_animates_a_caged_scene(scene, tmp_path):
    from puppet.imaging.io import load_rgba

    s = caged(animation={"fps": 5, "keys": [{"time": 0, "pose": "rest"}, {"time": 0.4, "pose": "p"}]})
    path = scene(s)
    png = tmp_path / "p.png"
    assert main(["render", path, "--pose", "p", "-o", str(png)]) == 0
    img = load_rgba(str(png))
    ink = np.argwhere(np.abs(img[..., :3].astype(int) - 255).max(axis=2) > 60)  # the box, not the white ground
    U = puppet.load_scene(path).layers("p")[0].deformed
    assert abs(ink[:, 1].max() - U[:, 0].max()) <= 2 and abs(ink[:, 0].max() - U[:, 1].max()) <= 2
    assert ink[:, 1].max() > 78  # widened past the rest box's right side (x = 75)
    gif = tmp_path / "a.gif"
    assert main(["animate", path, "-o", str(gif)]) == 0 and gif.stat().st_size > 0


def test_a_drag_moves_handles_and_pins_of_a_caged_layer_exactly(scene):
    doc = puppet.load_scene(scene(caged(pins=PINS[:2])))
    drag = doc.drag(["box:cage1", "tl"])
    targets = {"box:cage1": (86, 12), "tl": (29, 24)}
    preview = drag.move_layers(targets)[0]
    after = drag.release_layers()[0]
    assert np.array_equal(preview.deformed, after.deformed)  # a caged layer's preview is its exact pose
    assert after.exterior["box:cage1"] == [86.0, 12.0] and np.hypot(*(after.deformed[after.pins["tl"]] - (29, 24))) < 0.5
    assert doc.to_dict()["poses"][doc.active_pose] == {"box:cage1": [86.0, 12.0], "tl": [29.0, 24.0]}
    assert len(doc.history.undo_stack) == 1  # one undo step


def test_the_bundled_dress_fitted_narrower_through_an_automatic_cage(tmp_path):
    s = json.loads(open("assets/scenes/dress.json").read())
    s["source"] = os.path.abspath("assets/noto-emoji/emoji_u1f457.png")
    s["pins"] = [p for p in s["pins"] if p["name"] in ("strap_l", "strap_r", "hem_l", "hem_r")]
    s["layers"][0]["cage"] = {"auto": 16, "offset": 10}
    s["poses"] = {"narrow": {p["name"]: [250 + 0.75 * (p["at"][0] - 250), p["at"][1]] for p in s["pins"]}}
    path = tmp_path / "dress.json"
    path.write_text(json.dumps(s))
    doc = puppet.load_scene(str(path))
    rest, L = doc.layers("rest")[0], doc.layers("narrow")[0]
    for name, xy in s["poses"]["narrow"].items():
        assert np.hypot(*(L.deformed[L.pins[name]] - xy)) < 0.5
    def area(X):
        T = X[L.triangles]
        e, f = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
        return e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]
    assert (np.sign(area(L.deformed)) == np.sign(area(rest.rest))).all()  # no triangle folded
    assert np.ptp(L.deformed[:, 0]) < 0.85 * np.ptp(rest.rest[:, 0])  # narrower


def test_a_reordered_caged_layer_keeps_its_cage(scene):
    s = caged()
    s["layers"].insert(0, {"name": "bar", "image": "bar.png", "offset": [10, 10]})
    doc = puppet.load_scene(scene(s))
    before = doc.layers("p")[1].deformed
    doc.reorder_layer("box", 0)  # the same meshes, the caged layer now first
    L = doc.layers("p")
    assert L[0].name == "box" and np.array_equal(L[0].deformed, before) and set(L[0].exterior) == {
        f"box:cage{j}" for j in range(4)} and not L[1].exterior
