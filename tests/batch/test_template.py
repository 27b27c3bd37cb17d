"""Template (garment) mode: pins and poses of a template garment carried to other pictures."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from puppet.api import Scene
from puppet.batch.template import NUDGE, NoMatch, Template, on_mask, transfer
from puppet.errors import ImageError, SceneError
from puppet.scene.format.load import load_scene_data
from tests.batch import garments as G

TEMPLATE = G.TSHIRT_TEMPLATE


@pytest.fixture(scope="module")
def tshirt() -> Template:
    return Template(TEMPLATE)


@pytest.fixture(scope="module")
def pictures(tmp_path_factory):
    d = tmp_path_factory.mktemp("garments")
    a, b = G.similar_copy(G.TSHIRT, d / "copy.png", scale=0.6, angle=25.0, shift=(60, 10), size=(420, 400))
    kenney, edges = G.kenney_tshirt(d / "kenney.png")
    return {"copy": (str(d / "copy.png"), a, b), "warped": G.reproportioned(d / "warped.png"),
            "kenney": (kenney, edges), "circle": G.circle(d / "circle.png"), "dir": d}


def pins_of(doc: dict) -> dict[str, np.ndarray]:
    return {p["name"]: np.array(p["at"], float) for p in doc["pins"]}


def mask_of(doc: dict) -> np.ndarray:
    """The new layer's mask, as puppet builds it when it loads the scene."""
    scene = Scene(doc, os.path.join(os.path.dirname(doc["layers"][0]["image"]), "check.json"))
    return scene.built.images[0].mask  # building checks every pin is inside its mask


def assert_on_mask(doc: dict) -> None:
    """Every interior pin on a mask pixel (exterior pins may lie outside)."""
    mask = mask_of(doc)
    interior = {p["name"] for p in doc["pins"] if p.get("kind", "interior") == "interior"}
    for name, (x, y) in pins_of(doc).items():
        if name in interior:
            assert mask[int(np.floor(y)), int(np.floor(x))], f"{name} at {(x, y)} is off the mask"


def test_similarity_copy_gets_the_transformed_pins_and_poses(tshirt, pictures):
    path, a, b = pictures["copy"]
    r = tshirt.transfer(path)
    assert r.score < 0.01 and r.landmarks >= 5 and r.nudged == []
    assert abs(r.similarity.a - a) < 0.01 * abs(a) and abs(r.similarity.b - b) < 2.0
    got = pins_of(r.scene)
    for p in tshirt.pins:
        z = a * complex(*p.at) + b
        assert np.hypot(*(got[p.name] - [z.real, z.imag])) < 2.0, p.name
    # pose targets: the template's targets moved by the same similarity
    data = load_scene_data(TEMPLATE)
    for name, pose in data.poses.items():
        assert set(r.scene["poses"][name]) == set(pose)
        for pin, t in pose.items():
            z = a * complex(*t.to) + b
            new = r.scene["poses"][name][pin]
            to = new["to"] if isinstance(new, dict) else new
            assert np.hypot(to[0] - z.real, to[1] - z.imag) < 2.5, (name, pin)
            if isinstance(new, dict):
                assert new.get("angle", 0.0) == t.angle  # a similarity keeps relative turns
    # the rest of the scene: canvas of the picture, the template's layer settings, absolute paths
    assert r.scene["canvas"] == [420, 400]
    L = r.scene["layers"][0]
    assert L == {"name": "shirt", "image": os.path.abspath(path), "mask": "alpha", "mesh": {"max_area": 60}}
    assert r.scene["animation"] == data.raw["animation"]


def test_the_dress_template_takes_its_layer_from_source(pictures):
    """The bundled dress template: layer pixels from ``source``, default mask, exterior pins."""
    tpl = os.path.join(G.ROOT, "assets", "scenes", "dress-garment.json")
    path = pictures["dir"] / "dress.png"
    a, b = G.similar_copy(G.DRESS, path, scale=0.7, angle=-15.0, shift=(40, 80), size=(460, 460))
    doc = transfer(tpl, str(path))
    assert "source" not in doc and doc["layers"][0] == {"name": "dress", "image": str(path), "mesh": {"max_area": 40}}
    data = load_scene_data(tpl)
    got = pins_of(doc)
    assert len(got) == len(data.pins) == 12
    for p in data.pins:  # exterior pins (outside the mask) included
        z = a * complex(*p.at) + b
        assert np.hypot(*(got[p.name] - [z.real, z.imag])) < 2.0, p.name
    assert_on_mask(doc)
    with pytest.raises(NoMatch):
        transfer(tpl, G.TSHIRT)


def test_a_reproportioned_tshirt_gets_corresponding_pins(tshirt, pictures):
    doc = transfer(TEMPLATE, pictures["warped"])  # default tolerance
    assert_on_mask(doc)
    got = pins_of(doc)
    want = G.warp_forward([p.at for p in tshirt.pins])
    size = np.sqrt(mask_of(doc).sum())
    for p, w in zip(tshirt.pins, want):
        assert np.hypot(*(got[p.name] - w)) < 0.03 * size, p.name  # ~11 px on a 370 px garment


def test_a_kenney_tshirt_gets_its_pins_in_the_right_parts(tshirt, pictures):
    path, (body_l, body_r) = pictures["kenney"]
    r = tshirt.transfer(path, tolerance=0.15)  # a cropped, much wider shirt: score ~0.12
    assert 0.08 < r.score < 0.15
    assert abs(r.similarity.angle) < 10
    assert_on_mask(r.scene)
    got = pins_of(r.scene)
    assert got["sleeve_l"][0] < body_l and got["sleeve_r"][0] > body_r  # in the sleeves
    assert body_l < got["chest"][0] < body_r
    assert got["hem_c"][1] > got["chest"][1] > got["shoulder_l"][1]


@pytest.mark.parametrize("picture", ["dress", "circle", "pants", "trex"])
def test_other_kinds_do_not_match(tshirt, pictures, picture):
    path = {"dress": G.DRESS, "circle": pictures["circle"],
            "pants": os.path.join(G.KENNEY, "pantsLightBlue_long.png"),
            "trex": os.path.join(G.ROOT, "assets", "trex", "Body.PNG")}[picture]
    with pytest.raises(NoMatch, match=r"does not match .*distance 0\.\d+ .*> tolerance 0\.080 \(by 0\.\d+\)") as e:
        tshirt.transfer(path)
    assert isinstance(e.value, SceneError) and e.value.file == os.path.abspath(path)
    assert tshirt.transfer(path, tolerance=0.5).score > 0.1  # reported, not forced


def test_a_pin_that_cannot_be_placed_is_a_mismatch(tshirt):
    """Forced past the outline test, the running person leaves a sleeve pin in the air."""
    runner = os.path.join(G.ROOT, "assets", "noto-emoji", "emoji_u1f3c3.png")
    with pytest.raises(NoMatch, match=r"pin '\w+' lands .* outside the picture's mask .*outline match 0\.\d+"):
        tshirt.transfer(runner, tolerance=1.0)


def test_recoloured_and_scaled_kenney_shirt(tmp_path):
    """A template on Kenney's blue shirt: the red one (same outline) gets the same pins;
    a double-size copy gets them doubled."""
    shirt = os.path.join(G.KENNEY, "blueShirt1.png")
    tpl = tmp_path / "shirt.json"
    pins = {"neck_l": [40, 20], "neck_r": [112, 20], "belly": [76, 110], "hem_l": [30, 160]}
    tpl.write_text(json.dumps({"puppet": 1, "layers": [{"name": "shirt", "image": shirt}],
                               "pins": [{"name": k, "layer": "shirt", "at": v} for k, v in pins.items()],
                               "poses": {"tug": {"hem_l": {"to": [20, 170], "depth": 1.0}}},
                               "animation": {"fps": 10, "keys": [{"time": 0, "pose": "tug"},
                                                                 {"time": 1, "pins": {"hem_l": [25, 165]}}]}}))
    red = transfer(str(tpl), os.path.join(G.KENNEY, "redShirt1.png"))
    for name, xy in pins_of(red).items():
        assert np.hypot(*(xy - pins[name])) < 0.5
    assert red["poses"]["tug"]["hem_l"]["depth"] == 1.0
    assert np.allclose(red["poses"]["tug"]["hem_l"]["to"], [20, 170], atol=0.5)
    # a nearest-neighbour double: the mask is exactly the template's, doubled (a bilinear
    # upscale's alpha > 0 grows the outline by a pixel where the shirt is cut by the border)
    a, b = G.similar_copy(shirt, tmp_path / "big.png", scale=2.0, angle=0.0, shift=(0, 0), size=(306, 348),
                          nearest=True)
    big = transfer(str(tpl), str(tmp_path / "big.png"))
    for name, xy in pins_of(big).items():
        assert np.hypot(*(xy - 2 * np.array(pins[name]))) < 2.0
    # the displacement (-10, 10) doubled (by the fitted similarity, scale 2 within a percent)
    assert np.allclose(big["poses"]["tug"]["hem_l"]["to"], pins_of(big)["hem_l"] + [-20, 20], atol=0.3)
    keys = big["animation"]["keys"]
    assert keys[0] == {"time": 0, "pose": "tug"}  # inline pin targets of a key move like a pose's
    assert np.allclose(keys[1]["pins"]["hem_l"], pins_of(big)["hem_l"] + [-10, 10], atol=0.2)


def test_threshold_template_exterior_pins_and_layer_choice(tmp_path, pictures):
    """A two-layer template over an opaque picture (threshold mask) with an exterior pin
    and automatic exterior points moved by a pose."""
    from PIL import Image

    from puppet.scene.rig.exterior import auto_points

    flat = Image.new("RGBA", (512, 512), (255, 255, 255, 255))
    flat.alpha_composite(Image.open(G.TSHIRT).convert("RGBA"))
    flat.save(tmp_path / "flat.png")
    doc = json.loads(open(TEMPLATE).read())
    doc["layers"] = [{"name": "back", "image": "flat.png", "mask": {"rect": [0, 0, 40, 40]}},
                     {"name": "shirt", "image": "flat.png", "mask": {"threshold": 250},
                      "exterior": {"auto": True, "beta": 1.0}}]
    doc["pins"].append({"name": "cuff", "layer": "shirt", "at": [500, 150], "kind": "exterior"})
    doc["pins"].append({"name": "corner", "layer": "back", "at": [10, 10]})
    doc["poses"]["lift"]["cuff"] = [510, 100]
    doc["poses"]["lift"]["corner"] = [0, 0]
    doc["poses"]["lift"]["shirt:ext0"] = {"to": [500, 140], "angle": 5}
    tpl = tmp_path / "two.json"
    tpl.write_text(json.dumps(doc))
    with pytest.raises(SceneError, match="2 layers .*name the garment layer"):
        transfer(str(tpl), pictures["warped"])
    with pytest.raises(SceneError, match="no layer named 'front'"):
        transfer(str(tpl), pictures["warped"], layer="front")
    flat_copy = tmp_path / "copy.png"
    a, b = G.similar_copy(str(tmp_path / "flat.png"), flat_copy, scale=0.5, angle=-10, shift=(30, 60), size=(320, 320))
    arr = np.asarray(Image.open(flat_copy)).copy()
    arr[arr[..., 3] == 0] = 255  # opaque white around it, like a photo on white
    Image.fromarray(arr).save(flat_copy)
    new = transfer(str(tpl), str(flat_copy), layer="shirt")
    assert [L["name"] for L in new["layers"]] == ["shirt"]
    assert new["layers"][0]["mask"] == {"threshold": 250} and new["layers"][0]["exterior"]["beta"] == 1.0
    assert "corner" not in pins_of(new) and "corner" not in new["poses"]["lift"]
    cuff = pins_of(new)["cuff"]
    z = a * complex(500, 150) + b
    assert np.hypot(cuff[0] - z.real, cuff[1] - z.imag) < 2.0
    assert [p for p in new["pins"] if p["name"] == "cuff"][0]["kind"] == "exterior"
    # the automatic point ext0 of the template became the new picture's point at the same place
    ext_name = [k for k in new["poses"]["lift"] if k.startswith("shirt:ext")]
    assert len(ext_name) == 1
    j = int(ext_name[0].split("ext")[1])
    mask = mask_of(new)
    tpl_pt = auto_points(np.asarray(Image.open(tmp_path / "flat.png").convert("L")) < 250, (0, 0), 1.0)[0]
    new_pt = auto_points(mask, (0, 0), 1.0)[j]
    zt = a * complex(*tpl_pt) + b
    assert np.hypot(new_pt[0] - zt.real, new_pt[1] - zt.imag) < 4.0
    assert new["poses"]["lift"][ext_name[0]]["angle"] == 5


def test_unreadable_picture_is_an_image_error_not_a_mismatch(tmp_path, tshirt):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    with pytest.raises(ImageError) as e:
        tshirt.transfer(str(bad))
    assert not isinstance(e.value, NoMatch)
    with pytest.raises(ImageError):
        transfer(TEMPLATE, str(tmp_path / "missing.png"))


def test_on_mask_nudges_by_hand():
    m = np.zeros((10, 10), bool)
    m[4:6, 4:6] = True
    y, d = on_mask(m, np.array([4.2, 5.9]))  # pixel (5, 4) is a mask pixel
    assert d == 0.0 and np.array_equal(y, [4.2, 5.9])
    y, d = on_mask(m, np.array([7.5, 5.5]))  # two pixels right of the block
    assert np.allclose(y, [5.5, 5.5]) and d == pytest.approx(2.0)
    _, d = on_mask(m, np.array([9.9, 0.1]))
    assert d > NUDGE


@pytest.mark.gl
def test_the_transferred_scene_renders_its_pose(tshirt, pictures, tmp_path):
    doc = tshirt.transfer(pictures["warped"]).scene
    scene = Scene(doc, str(tmp_path / "warped.json"))
    try:
        rest = scene.render(size=(140, 128))
        lift = scene.render(pose="lift", size=(140, 128))
        assert rest.shape == lift.shape == (128, 140, 4)
        assert np.abs(rest.astype(int) - lift.astype(int)).max() > 100  # the sleeves moved
        # lifted sleeves: the shirt covers more of the top rows
        def top(im):
            return (np.abs(im[:40, :, :3].astype(int) - [250, 246, 238]).sum(axis=2) > 30).sum()
        assert top(lift) > top(rest)
        scene.save(str(tmp_path / "warped.json"))  # a scene file with relative paths that loads again
    finally:
        scene.close()
    again = Scene.load(str(tmp_path / "warped.json"))
    try:
        assert np.array_equal(again.render(pose="lift", size=(140, 128)), lift)
    finally:
        again.close()


def test_key_overrides_and_physics_chains_are_carried(pictures, tmp_path):
    raw = json.loads(open(TEMPLATE).read())
    raw["layers"][0]["image"] = os.path.join(os.path.dirname(TEMPLATE), raw["layers"][0]["image"])
    pose = next(iter(raw["poses"]))
    raw["animation"] = {"fps": 12, "keys": [{"time": 0, "pose": "rest"},
                                            {"time": 1, "pose": pose, "overrides": {"sleeve_l": [60, 150],
                                                                                    "hem_c": None}}]}
    raw["physics"] = {"chains": [{"pins": ["shoulder_l", "sleeve_l"], "damping": 0.5}]}
    path = tmp_path / "t.json"
    path.write_text(json.dumps(raw))
    pic, a, b = pictures["copy"]
    r = Template(str(path)).transfer(pic)
    over = r.scene["animation"]["keys"][1]["overrides"]
    z = a * complex(60, 150) + b
    assert over["hem_c"] is None and np.hypot(over["sleeve_l"][0] - z.real, over["sleeve_l"][1] - z.imag) < 2.5
    assert r.scene["physics"] == raw["physics"]
    Scene(r.scene, os.path.join(str(tmp_path), "t2.json")).layers(time=0.5)  # the carried scene plays
