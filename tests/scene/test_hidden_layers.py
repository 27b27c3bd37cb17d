"""A layer the scene hides (``layers[i].visible: false``, issue 32: imports kept hidden
layers out of the scene): it is built and posed (its pins and links work, ``puppet mesh``
writes it) but not drawn, and the exports leave it out of what they show."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

import puppet
from puppet.cli import main
from puppet.errors import SceneError
from tests.conftest import bar_image


def two_bars(hidden: bool) -> dict:
    """A red bar and, in front of it, a separate blue one (no link: each its own group)."""
    s = {"puppet": 1, "canvas": [160, 80], "background": [255, 255, 255, 255],
         "layers": [{"name": "red", "image": "red.png"},
                    {"name": "blue", "image": "blue.png", "offset": [20, 20]}],
         "pins": [{"name": "r", "layer": "red", "at": [30, 20]}, {"name": "b", "layer": "blue", "at": [60, 40]}],
         "poses": {"up": {"b": [60, 30]}}}
    if hidden:
        s["layers"][1]["visible"] = False
    return s


@pytest.fixture
def scenes(make_scene):
    files = {"red.png": bar_image(160, 80, (10, 10, 150, 30), (200, 40, 40)),
             "blue.png": bar_image(120, 40, (10, 10, 110, 30), (40, 40, 200))}
    return make_scene(two_bars(False), files), make_scene(two_bars(True), files, name="hidden.json")


def test_the_flag_is_read_checked_written_and_edited(scenes):
    shown, hidden = scenes
    doc = puppet.load_scene(hidden)
    assert [L.visible for L in doc.data.layers] == [True, False]
    assert doc.to_dict()["layers"][1]["visible"] is False
    doc.set_layer("blue", visible=True)
    assert "visible" not in doc.to_dict()["layers"][1] and doc.data.layers[1].visible
    assert doc.history.undo_stack[-1].label == "show layer blue"  # the History panel's line
    doc.undo()
    assert not doc.data.layers[1].visible
    bad = json.loads(open(hidden).read())
    bad["layers"][1]["visible"] = "no"
    with open(hidden, "w") as f:
        json.dump(bad, f)
    with pytest.raises(SceneError, match=r"layers\[1\]\.visible"):
        puppet.load_scene(hidden)


@pytest.mark.gl
def test_a_hidden_layer_is_posed_but_not_drawn(scenes, tmp_path):
    shown, hidden = scenes
    a, b = puppet.load_scene(shown), puppet.load_scene(hidden)
    pa, pb = a.layers("up"), b.layers("up")
    assert all(np.array_equal(x.deformed, y.deformed) for x, y in zip(pa, pb))  # posed the same
    img = b.render(pose="up")
    assert abs(img[35, 80, :3].astype(int) - (255, 255, 255)).max() <= 1  # where the blue bar would be
    assert abs(a.render(pose="up")[35, 80, :3].astype(int) - (40, 40, 200)).max() <= 2
    assert abs(img[20, 80, :3].astype(int) - (200, 40, 40)).max() <= 2  # the red bar is drawn
    out = tmp_path / "mesh.json"
    assert main(["mesh", hidden, "--pose", "up", "-o", str(out)]) == 0
    assert [L["name"] for L in json.loads(out.read_text())["layers"]] == ["red", "blue"]  # posed: its mesh written


@pytest.mark.gl
def test_exports_leave_a_hidden_layer_out_of_what_they_show(scenes, tmp_path):
    _, hidden = scenes
    doc = json.loads(open(hidden).read())
    doc["animation"] = {"keys": [{"time": 0, "pose": "rest"}, {"time": 0.5, "pose": "up"}]}
    with open(hidden, "w") as f:
        json.dump(doc, f)
    spine = tmp_path / "s.spine.json"
    assert main(["animate", hidden, "-o", str(spine), "--format", "spine"]) == 0
    slots = {s["name"]: s for s in json.loads(spine.read_text())["slots"]}
    assert "attachment" in slots["red"] and "attachment" not in slots["blue"]  # in the skin, not shown
    pygltflib = pytest.importorskip("pygltflib")
    glb = tmp_path / "s.glb"
    assert main(["animate", hidden, "-o", str(glb)]) == 0
    g = pygltflib.GLTF2().load_binary(str(glb))
    root = next(n for n in g.nodes if n.name == "puppet")
    assert [g.nodes[k].name for k in root.children] == ["red"]
    page = tmp_path / "s.html"
    assert main(["animate", hidden, "-o", str(page)]) == 0
    meta = json.loads(re.search(r'id="puppet-meta"[^>]*>(.*?)</script>', page.read_text(), re.S).group(1))
    blue = next(L for L in meta["layers"] if L["name"] == "blue")
    assert blue["opaque"] == 0 and blue["edge"] == 0 and blue["n"] > 0  # its vertices kept, nothing drawn
    gif = tmp_path / "s.gif"
    assert main(["animate", hidden, "-o", str(gif)]) == 0
    from PIL import Image

    with Image.open(gif) as im:
        frame = np.asarray(im.convert("RGB")).astype(int)
    assert abs(frame[45, 80] - (255, 255, 255)).max() <= 8


def test_a_hidden_layer_nothing_rigs_costs_two_triangles_until_shown(scenes):
    """A hidden layer without pins or links (an imported sketch) gets a stand-in mesh,
    its mask's box; a pin on it, or showing it, meshes it for real."""
    shown, hidden = scenes
    real = len(puppet.load_scene(shown).built.meshes[1].V)
    doc = json.loads(open(hidden).read())
    doc["pins"] = [p for p in doc["pins"] if p["layer"] != "blue"]
    doc.pop("poses")
    with open(hidden, "w") as f:
        json.dump(doc, f)
    s = puppet.load_scene(hidden)
    m = s.built.meshes[1]
    assert len(m.V) == 4 and len(m.F) == 2
    assert m.V.min(axis=0).tolist() == [30.0, 30.0] and m.V.max(axis=0).tolist() == [130.0, 50.0]  # the bar's box
    s.set_layer("blue", visible=True)
    assert len(s.built.meshes[1].V) > 4
    s.undo()
    s.add_pin("b", "blue", (60, 40))
    assert len(s.built.meshes[1].V) == real
