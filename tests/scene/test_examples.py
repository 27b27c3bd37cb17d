"""The example scenes of "Layers for real pictures": the Kenney character assembled from
cut-out parts, the Noto dress as a garment, the T-rex with parts cut out of its flat
picture (see docs/examples/README.md)."""
import json
import os

import numpy as np
import pytest
from PIL import Image

import puppet
from tests.conftest import ASSETS, ROOT, SCENES

CHARACTER = os.path.join(SCENES, "character.json")
DRESS = os.path.join(SCENES, "dress-garment.json")
TREX = os.path.join(SCENES, "trex-cutout-inpaint.json")
TREX_NONE = os.path.join(ROOT, "docs", "examples", "trex-cutout-inpaint-none.json")
EXAMPLES = [CHARACTER, DRESS, TREX, TREX_NONE]

_loaded = {}


def scene(path):
    """Each scene is loaded (images, masks, meshes, factorisations) once for the module."""
    if path not in _loaded:
        _loaded[path] = puppet.load_scene(path)
    return _loaded[path]


def targets(path, pose):
    """Interior pin name -> where the pose puts it (pins it does not name stay at rest)."""
    d = json.load(open(path))
    out = {}
    for p in d["pins"]:
        if p.get("kind", "interior") != "interior":
            continue
        t = d["poses"].get(pose, {}).get(p["name"], p["at"]) if pose != "rest" else p["at"]
        if isinstance(t, dict):
            t = t.get("to", p["at"])
        out[p["name"]] = np.asarray(t, float)
    return out


def cases():
    for path in EXAMPLES:
        for pose in ["rest"] + list(json.load(open(path))["poses"]):
            yield pytest.param(path, pose, id=f"{os.path.basename(path)[:-5]}-{pose}")


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: os.path.basename(p)[:-5])
def test_example_loads_with_one_linked_group(path):
    sc = scene(path)
    assert len(sc.groups) == 1  # every part is linked to the others
    assert sc.data.animation is not None and len(sc.data.poses) >= 3


@pytest.mark.parametrize("path,pose", list(cases()))
def test_every_pose_puts_pins_on_targets(path, pose):
    want = targets(path, pose)
    seen = set()
    for r in scene(path).layers(pose):
        assert np.isfinite(r.deformed).all() and np.isfinite(r.depth).all(), r.name
        for name, v in r.pins.items():
            assert np.linalg.norm(r.deformed[v] - want[name]) < 1e-6, (r.name, name)
            seen.add(name)
        for name, xy in r.exterior.items():
            assert np.isfinite(xy).all(), name
    assert seen == set(want)


# -- the character -------------------------------------------------------------------
def _moved(r):
    return np.linalg.norm(r.deformed - r.rest, axis=1)


def test_character_sleeve_follows_the_waving_hand_and_the_other_leg_stays():
    sc = scene(CHARACTER)
    res = {r.name: r for r in sc.layers("wave")}
    hand = res["hand_r"]
    v = hand.pins["hand_r"]
    drag = np.linalg.norm(hand.deformed[v] - hand.rest[v])
    assert drag > 200
    assert _moved(res["sleeve_r"]).mean() > 0.3 * drag  # the garment goes along with the limb
    assert _moved(res["arm_r"]).mean() > 0.3 * drag
    for name in ("leg_l", "shoe_l", "trouser_l"):  # foot_l is pinned at rest: that leg stays
        assert _moved(res[name]).max() < 2.0, name


def test_character_trouser_leg_follows_the_kicking_foot():
    res = {r.name: r for r in scene(CHARACTER).layers("kick")}
    shoe = res["shoe_r"]
    v = shoe.pins["foot_r"]
    drag = np.linalg.norm(shoe.deformed[v] - shoe.rest[v])
    assert drag > 100
    assert _moved(res["trouser_r"]).mean() > 0.3 * drag
    assert _moved(res["leg_r"]).mean() > 0.3 * drag
    assert _moved(res["hand_l"]).max() < 2.0


def test_character_links_hold_garments_on_limbs():
    """Link vertices are shared: after a pose, each sleeve/trouser link point is at the
    same place in the garment and in the limb under it."""
    d = json.load(open(CHARACTER))
    res = {r.name: r for r in scene(CHARACTER).layers("wave")}
    for link in d["links"]:
        a, b = (res[n] for n in link["layers"])
        for seg in link["segments"]:
            for p in np.asarray(seg, float):
                ia = np.argmin(np.linalg.norm(a.rest - p, axis=1))
                ib = np.argmin(np.linalg.norm(b.rest - p, axis=1))
                assert np.linalg.norm(a.rest[ia] - p) < 1e-6 and np.linalg.norm(b.rest[ib] - p) < 1e-6
                assert np.linalg.norm(a.deformed[ia] - b.deformed[ib]) < 1e-6, link["layers"]


def test_character_hand_goes_behind_the_body_shoulder_stays_in_front():
    res = {r.name: r for r in scene(CHARACTER).layers("behind")}
    shirt = res["shirt"]
    hand = res["hand_r"]
    sleeve = res["sleeve_r"]
    assert hand.depth[hand.pins["hand_r"]] < shirt.order - 1  # behind the shirt
    assert sleeve.depth[sleeve.pins["shoulder_r"]] > shirt.depth.max()  # the shoulder is not
    assert sleeve.depth.min() < shirt.depth.min()  # the sleeve passes behind the shirt on its way


def test_character_parts_are_mirrored_copies():
    d = json.load(open(CHARACTER))
    layers = {L["name"]: L for L in d["layers"]}
    W = d["canvas"][0]
    for part in ("arm", "sleeve", "hand", "leg", "trouser", "shoe"):
        right, left = layers[part + "_r"], layers[part + "_l"]
        a = np.array(Image.open(os.path.join(SCENES, right["image"])).convert("RGBA"))
        b = np.array(Image.open(os.path.join(SCENES, left["image"])).convert("RGBA"))
        assert np.array_equal(a[:, ::-1], b), part
        assert left["offset"] == [W - right["offset"][0] - a.shape[1], right["offset"][1]], part


# -- the T-rex cut out of one picture ------------------------------------------------------
GREEN = np.array([158, 255, 194])  # the T-rex's one body colour


def _under_parts(sc):
    fig = sc.images[0]
    return fig.mask & np.logical_or.reduce([im.mask for im in sc.images[1:]])


def test_trex_figure_refills_what_the_cut_parts_took():
    """Under the cut parts the figure keeps a copy of them with no inpainting (the jaw's
    white teeth stay on the upper head) and its own body colour with telea."""
    telea, none = scene(TREX), scene(TREX_NONE)
    assert [L.inpaint for L in telea.data.layers][0] == "telea"
    assert [L.inpaint for L in none.data.layers][0] == "none"
    hole = _under_parts(telea)
    assert np.array_equal(hole, _under_parts(none)) and hole.sum() > 5000
    white_none = (none.images[0].rgba[..., :3].min(-1) > 230) & hole
    white_telea = (telea.images[0].rgba[..., :3].min(-1) > 230) & hole
    assert white_none.sum() > 1000  # the teeth left behind
    assert white_telea.sum() == 0
    jaw = telea.images[[L.name for L in telea.data.layers].index("jaw")]
    teeth = (jaw.rgba[..., :3].min(-1) > 230) & jaw.mask
    assert teeth.sum() > 1000  # the jaw layer itself carries them
    fill = telea.images[0].rgba[hole][:, :3].astype(float)
    assert np.linalg.norm(fill - GREEN, axis=1).mean() < 10
    # pixels outside the parts are the picture's own, untouched
    keep = telea.images[0].mask & ~hole
    assert np.array_equal(telea.images[0].rgba[keep], none.images[0].rgba[keep])


def test_trex_figure_keeps_no_copy_of_the_arm_sticking_out():
    """The arm is the body's green, so its copy would show as a shape: the figure's mask
    keeps only the arm's root inside the body, never the arm sticking out of it."""
    sc = scene(TREX)
    names = [L.name for L in sc.data.layers]
    arm = sc.images[names.index("arm")].mask
    fig = sc.images[0].mask
    body = np.array(Image.open(os.path.join(ASSETS, "trex", "Body.PNG")).convert("RGBA"))[..., 3] > 0
    assert (arm & fig).sum() < 0.2 * arm.sum()
    assert not (arm & fig & ~body).any()


@pytest.mark.gl
def test_trex_reach_shows_background_where_the_arm_was():
    sc = scene(TREX)
    names = [L.name for L in sc.data.layers]
    arm = sc.images[names.index("arm")].mask
    link = next(L for L in json.load(open(TREX))["links"] if "arm" in L["layers"])
    hinge = np.mean(link["segments"][0], axis=0)
    ys, xs = np.nonzero(arm)
    far = np.hypot(xs + 0.5 - hinge[0], ys + 0.5 - hinge[1]) > 30  # the forearm and the hand
    img = sc.render("reach")
    px = img[ys[far], xs[far], :3]
    assert (px.min(axis=1) > 245).mean() > 0.95  # white background, no arm left behind
