"""Deformation that fits real art (issue 22), through scenes: modes, painted stiffness,
starch pins, hinge links, patches, link strength, clipped segments."""
import copy
import json
import os

import numpy as np
import pytest

import puppet
from puppet.errors import SceneError
from puppet.geom.triangulate import signed_areas

ASSETS = os.path.join(os.path.dirname(__file__), "..", "..", "assets", "scenes")


def distortion(V, U, F, sel=None) -> float:
    """Area-weighted mean over triangles of sum_i (sigma_i - 1)^2 (singular values of the
    deformation gradient)."""
    a, b = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    c, d = U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]
    J = np.stack([c, d], 2) @ np.linalg.inv(np.stack([a, b], 2))
    e = ((np.linalg.svd(J, compute_uv=False) - 1) ** 2).sum(1)
    area = np.abs(0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    if sel is not None:
        e, area = e[sel], area[sel]
    return float((e * area).sum() / area.sum())


def area_ratio(results) -> float:
    return sum(-signed_areas(r.deformed, r.triangles).sum() for r in results) / \
        sum(-signed_areas(r.rest, r.triangles).sum() for r in results)


def folds(results) -> int:
    return int(sum((signed_areas(r.deformed, r.triangles) >= 0).sum() for r in results))


def test_distortion_metric_by_hand():
    V = np.array([[0, 0], [1, 0], [0, 1.0]])
    F = np.array([[0, 1, 2]])
    assert distortion(V, V, F) == 0
    assert distortion(V, V * 0.5, F) == pytest.approx(0.5)  # two singular values 0.5
    R = np.array([[0, -1], [1, 0.0]])
    assert distortion(V, V @ R.T + 3, F) == pytest.approx(0, abs=1e-12)


# -- modes -------------------------------------------------------------------------
def bar_image():
    a = np.zeros((120, 440, 4), np.uint8)
    a[20:100, 20:420] = (200, 60, 60, 255)  # 400 x 80
    return a


def bar_scene(mode=None):
    s = {"puppet": 1, "layers": [{"name": "bar", "image": "bar.png"}],
         "pins": [{"name": "l", "layer": "bar", "at": [30, 60]}, {"name": "r", "layer": "bar", "at": [410, 60]}],
         "poses": {"squeeze": {"l": [106, 60], "r": [334, 60]}}}  # 60 % of the distance
    if mode is not None:
        s["deformer"] = {"mode": mode}
    return s


def test_similar_shrinks_a_bar_evenly(make_scene):
    sc = puppet.load_scene(make_scene(bar_scene("similar"), {"bar.png": bar_image()}))
    res = sc.layers("squeeze")
    assert area_ratio(res) == pytest.approx(0.36, abs=0.04)
    assert folds(res) == 0
    (r,) = res
    # evenly: every triangle scaled by 0.6
    assert distortion(r.rest, r.deformed, r.triangles) == pytest.approx(2 * 0.4 ** 2, abs=0.01)


def test_rigid_is_the_default_bit_for_bit(make_scene):
    imgs = {"bar.png": bar_image()}
    plain = puppet.load_scene(make_scene(bar_scene(), imgs, name="a.json")).layers("squeeze")[0]
    rigid = puppet.load_scene(make_scene(bar_scene("rigid"), imgs, name="b.json")).layers("squeeze")[0]
    assert np.array_equal(plain.deformed, rigid.deformed)
    # rigid ARAP keeps the bar's length: it does not shrink evenly
    assert area_ratio([rigid]) > 0.6


@pytest.mark.parametrize("mode", ["rigid", "similar", "distort"])
def test_every_mode_rest_pins_rotation_and_trajectory_invariance(make_scene, mode):
    s = bar_scene(mode)
    c = np.array([220.0, 60.0])
    R = np.array([[0, 1], [-1, 0.0]])  # 90 degrees counter-clockwise on screen (y down)
    s["poses"]["turn"] = {n: (c + R @ (np.array(p) - c)).tolist() for n, p in (("l", [30, 60]), ("r", [410, 60]))}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))
    (r,) = sc.layers()
    assert np.abs(r.deformed - r.rest).max() < 1e-9
    (t,) = sc.layers("turn")
    assert np.abs(t.deformed - ((r.rest - c) @ R.T + c)).max() < 1e-6
    a = sc.layers("squeeze")[0].deformed
    sc.layers("turn")
    assert np.array_equal(sc.layers("squeeze")[0].deformed, a)


def test_distort_stretches_between_rigid_and_similar(make_scene):
    imgs = {"bar.png": bar_image()}
    ratios = {m: area_ratio(puppet.load_scene(make_scene(bar_scene(m), imgs, name=f"{m}.json")).layers("squeeze"))
              for m in ("rigid", "similar", "distort")}
    assert ratios["similar"] < ratios["distort"] < ratios["rigid"]


def test_layer_mode_overrides_the_scene(make_scene):
    s = bar_scene("rigid")
    s["layers"][0]["deformer"] = {"mode": "similar"}
    res = puppet.load_scene(make_scene(s, {"bar.png": bar_image()})).layers("squeeze")
    assert area_ratio(res) == pytest.approx(0.36, abs=0.04)


def test_modes_refuse_other_methods(make_scene):
    s = bar_scene()
    s["layers"][0]["deformer"] = {"mode": "distort"}
    s["deformer"] = {"method": "mls"}
    with pytest.raises(SceneError, match=r"layers\[0\]\.deformer\.mode: .*needs deformer\.method 'arap'"):
        puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))


def screen_angle(V0, U, mask) -> float:
    """Procrustes turn of the points ``mask`` from V0 to U, degrees counter-clockwise on screen."""
    X, Y = V0[mask] - V0[mask].mean(0), U[mask] - U[mask].mean(0)
    return -np.degrees(np.arctan2((X[:, 0] * Y[:, 1] - X[:, 1] * Y[:, 0]).sum(), (X * Y).sum()))


@pytest.mark.parametrize("mode", ["rigid", "similar", "distort"])
def test_pin_angles_in_every_mode(make_scene, mode):
    s = bar_scene(mode)
    s["poses"]["twist"] = {"l": [106, 60], "r": {"to": [334, 60], "angle": 30}}
    (r,) = puppet.load_scene(make_scene(s, {"bar.png": bar_image()})).layers("twist")
    near = np.linalg.norm(r.rest - [410, 60], axis=1) < 30
    assert screen_angle(r.rest, r.deformed, near) == pytest.approx(30, abs=3)
    assert folds([r]) == 0
    assert np.allclose(r.deformed[r.pins["r"]], [334, 60])


@pytest.mark.parametrize("mode", ["similar", "distort"])
def test_modes_with_inbetweens_and_exterior_points(make_scene, mode):
    s = bar_scene(mode)
    s["layers"][0]["exterior"] = {"auto": True, "beta": 2}
    s["animation"] = {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "squeeze"}]}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))
    key = sc.layers("squeeze")[0]
    assert np.allclose(sc.layers(time=1.0)[0].deformed, key.deformed)
    mid = sc.layers(time=0.5)
    assert folds(mid) == 0
    assert area_ratio([key]) < area_ratio(mid) < 1.0
    assert key.exterior  # exterior points ride along in every mode


@pytest.mark.parametrize("name", ["dress-garment", "tshirt-garment"])
def test_garment_narrowed_in_similar_mode(name, tmp_path):
    res = puppet.load_scene(narrowed_garment(name, tmp_path)).layers("narrow")
    assert folds(res) == 0
    assert area_ratio(res) == pytest.approx(0.5625, abs=0.05)


def narrowed_garment(name: str, tmp_path) -> str:
    """A copy of bundled garment scene ``name`` fitted in ``similar`` mode, with a pose
    "narrow" that brings every pin 3/4 of the way to their centroid; its path."""
    raw = json.load(open(os.path.join(ASSETS, name + ".json")))
    pins = [p for p in raw["pins"] if p.get("kind", "interior") == "interior"]
    c = np.mean([p["at"] for p in pins], axis=0)
    s = copy.deepcopy(raw)
    s["deformer"] = dict(s.get("deformer", {}), mode="similar")
    s["poses"] = {"narrow": {p["name"]: (c + 0.75 * (np.array(p["at"]) - c)).tolist() for p in pins}}
    s.pop("animation", None)
    here = lambda f: os.path.abspath(os.path.join(ASSETS, f))  # noqa: E731
    if "source" in s:
        s["source"] = here(s["source"])
    for L in s["layers"]:
        if "image" in L:
            L["image"] = here(L["image"])
        if isinstance(L.get("mask"), dict) and "file" in L["mask"]:
            L["mask"]["file"] = here(L["mask"]["file"])
    path = tmp_path / "garment.json"
    path.write_text(json.dumps(s))
    return str(path)


# -- links: hinges, patches, strength, clipping ---------------------------------------
W, H = 360, 260


def arm_images():
    body = np.zeros((H, W, 4), np.uint8)
    body[100:220, 20:220] = (90, 140, 200, 255)
    arm = np.zeros((H, W, 4), np.uint8)
    arm[110:140, 180:320] = (220, 160, 60, 255)
    return {"body.png": body, "arm.png": arm}


def arm_scene(**link):
    return {"puppet": 1, "canvas": [W, H],
            "layers": [{"name": "body", "image": "body.png"}, {"name": "arm", "image": "arm.png"}],
            "links": [dict(layers=["body", "arm"], **link)],
            "pins": [{"name": "hip", "layer": "body", "at": [60, 190]},
                     {"name": "chest", "layer": "body", "at": [120, 130]},
                     {"name": "tip", "layer": "arm", "at": [310, 125]}],
            "poses": {"up": {"tip": [200, 15]}}}  # 90 degrees about (200, 125)


def body_moved(res, hinge=(200, 125), radius=12):
    body = res[0]
    far = np.linalg.norm(body.rest - np.array(hinge), axis=1) > radius
    return float(np.linalg.norm(body.deformed - body.rest, axis=1)[far].max())


def test_hinge_turns_the_arm_without_dragging_the_body(make_scene):
    sc = puppet.load_scene(make_scene(arm_scene(points=[[200, 125]]), arm_images()))
    res = sc.layers("up")
    assert body_moved(res) <= 2.0
    arm = res[1]
    assert distortion(arm.rest, arm.deformed, arm.triangles) <= 0.02
    # the two layers share one vertex at the hinge
    hb = np.flatnonzero(np.all(res[0].rest == [200, 125], axis=1))
    ha = np.flatnonzero(np.all(arm.rest == [200, 125], axis=1))
    assert len(hb) == 1 and len(ha) == 1
    assert np.array_equal(res[0].deformed[hb], arm.deformed[ha])
    assert len(sc.built.groups) == 1


def test_segment_link_makes_the_body_follow(make_scene):
    res = puppet.load_scene(make_scene(arm_scene(segments=[[[185, 125], [215, 125]]]), arm_images())).layers("up")
    assert body_moved(res) > 10.0  # the shoulder is a seam: the body bends with the arm


def test_strength_loosens_the_coupling(make_scene):
    imgs = arm_images()
    gap = {}
    for s in (0.2, 0.9):
        res = puppet.load_scene(make_scene(arm_scene(segments=[[[185, 125], [215, 125]]], strength=s), imgs,
                                           name=f"s{s}.json")).layers("up")
        body, arm = res
        seam = [(i, j) for i, p in enumerate(body.rest) if abs(p[1] - 125) < 1e-9 and 185 <= p[0] <= 215
                for j in np.flatnonzero(np.all(arm.rest == p, axis=1))]
        assert len(seam) >= 3  # the segment's vertices, in both layers
        gap[s] = max(float(np.linalg.norm(body.deformed[i] - arm.deformed[j])) for i, j in seam)
    assert gap[0.2] > gap[0.9] > 0


@pytest.mark.parametrize("link", [dict(points=[[200, 125]], strength=0.9),
                                  dict(segments=[[[185, 125], [215, 125]]], strength=0.9)])
def test_weak_links_stay_closed_between_keys(make_scene, link):
    s = arm_scene(**link)
    s["animation"] = {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "up"}]}
    sc = puppet.load_scene(make_scene(s, arm_images()))
    for t in (0.5, 1.0):
        body, arm = sc.layers(time=t)
        seam = [(i, j) for i, p in enumerate(body.rest) if abs(p[1] - 125) < 1e-9 and 185 <= p[0] <= 215
                for j in np.flatnonzero(np.all(arm.rest == p, axis=1))]
        assert seam
        gap = max(float(np.linalg.norm(body.deformed[i] - arm.deformed[j])) for i, j in seam)
        assert gap < 1.0, (t, gap)  # the springs hold the seam in the in-betweens too
    if "points" in link:  # a weak hinge is guessed like a hinge: the body stays
        assert body_moved(sc.layers("up")) <= 2.0


def test_polygon_patch_moves_as_one(make_scene):
    patch = [[185, 113], [215, 113], [215, 137], [185, 137]]
    sc = puppet.load_scene(make_scene(arm_scene(polygons=[patch]), arm_images()))
    body, arm = sc.layers("up")
    inside = (arm.rest[:, 0] > 186) & (arm.rest[:, 0] < 214) & (arm.rest[:, 1] > 114) & (arm.rest[:, 1] < 136)
    tri = np.all(inside[arm.triangles], axis=1)
    assert tri.sum() > 3
    assert distortion(arm.rest, arm.deformed, arm.triangles, tri) < 0.01


def test_segment_leaving_the_overlap_is_clipped_with_a_note(make_scene):
    sc = puppet.load_scene(make_scene(arm_scene(segments=[[[150, 125], [215, 125]]]), arm_images()))
    notes = sc.built.notes
    assert len(notes) == 1 and notes[0].startswith("links[0].segments[0]: the part outside")
    assert any(n == notes[0] for n in sc.not_applied())
    body, arm = sc.layers()
    assert np.abs(body.deformed - body.rest).max() < 1e-9
    # the clipped segment starts inside the arm's mask (x >= 180)
    on_arm = arm.rest[np.isclose(arm.rest[:, 1], 125) & (arm.rest[:, 0] < 181)]
    assert len(on_arm) == 0 or on_arm[:, 0].min() >= 179.5


# -- stiffness -------------------------------------------------------------------------
def strip_scene(stiffness=None, mode="rigid", starch=False):
    L = {"name": "s", "image": "strip.png"}
    if stiffness:
        L["stiffness"] = {"file": "paint.png"}
    pins = [{"name": "l", "layer": "s", "at": [30, 70]}, {"name": "m", "layer": "s", "at": [220, 70]},
            {"name": "r", "layer": "s", "at": [410, 70]}]
    if starch:
        pins.append({"name": "starch", "layer": "s", "at": [150, 70], "kind": "starch", "radius": 60})
    return {"puppet": 1, "canvas": [440, 240], "layers": [L], "pins": pins, "deformer": {"mode": mode},
            "poses": {"bend": {"l": [70, 170], "r": [370, 170]}}}


def strip_images():
    strip = np.zeros((240, 440, 4), np.uint8)
    strip[40:100, 20:420] = (120, 180, 90, 255)
    paint = np.zeros((240, 440, 4), np.uint8)
    paint[..., 3] = 255
    paint[:, 120:180, :3] = 255
    return {"strip.png": strip, "paint.png": paint}


def band_distortion(res):
    (r,) = res
    c = r.rest[r.triangles].mean(1)
    band = (c[:, 0] > 120) & (c[:, 0] < 180)
    return distortion(r.rest, r.deformed, r.triangles, band)


@pytest.mark.parametrize("mode", ["rigid", "similar", "distort"])
def test_painted_band_keeps_its_shape(make_scene, mode):
    imgs = strip_images()
    plain = band_distortion(puppet.load_scene(make_scene(strip_scene(None, mode), imgs, name="a.json")).layers("bend"))
    painted = puppet.load_scene(make_scene(strip_scene("paint", mode), imgs, name="b.json")).layers("bend")
    assert plain > 1e-3  # the band does bend when unpainted
    assert band_distortion(painted) <= 0.25 * plain
    assert folds(painted) == 0


def test_starch_pin_stiffens_without_holding(make_scene):
    imgs = strip_images()
    plain = puppet.load_scene(make_scene(strip_scene(), imgs, name="a.json"))
    starch = puppet.load_scene(make_scene(strip_scene(starch=True), imgs, name="b.json"))
    assert band_distortion(starch.layers("bend")) <= 0.25 * band_distortion(plain.layers("bend"))
    assert np.abs(starch.layers()[0].deformed - starch.layers()[0].rest).max() < 1e-9
    (r,) = starch.layers("bend")
    assert "starch" not in r.pins  # not a mesh vertex, holds no position


def test_stiffness_image_must_match_the_layer(make_scene):
    imgs = strip_images()
    imgs["paint.png"] = imgs["paint.png"][:100]
    with pytest.raises(SceneError, match=r"layers\[0\]\.stiffness\.file: stiffness image is 440x100"):
        puppet.load_scene(make_scene(strip_scene("paint"), imgs)).layers("bend")


def test_saved_elsewhere_keeps_the_stiffness_image(make_scene, tmp_path):
    from puppet.scene.document.core import Document
    from puppet.scene.format.inputs import input_files

    path = make_scene(strip_scene("paint"), strip_images())
    doc = Document.load(path)
    assert (os.path.join(os.path.dirname(path), "paint.png"), "layers[0].stiffness.file") in input_files(doc.data)
    os.makedirs(tmp_path / "elsewhere")
    out = str(tmp_path / "elsewhere" / "moved.json")
    doc.save(out)
    saved = json.load(open(out))
    assert saved["layers"][0]["stiffness"]["file"] == "../paint.png"
    a = Document.load(path).layers("bend")[0].deformed
    assert np.array_equal(Document.load(out).layers("bend")[0].deformed, a)


def test_check_prints_the_clipping_note(make_scene, capsys):
    from puppet.cli import main

    path = make_scene(arm_scene(segments=[[[150, 125], [215, 125]]]), arm_images())
    assert main(["check", path]) == 0
    out = capsys.readouterr().out
    assert "note: links[0].segments[0]: the part outside layers 'body' and 'arm' was cut off" in out
    s = arm_scene(points=[[200, 125]], strength=0.5)
    s["layers"][1]["deformer"] = {"mode": "similar"}
    assert main(["check", make_scene(s, arm_images(), name="hinge.json")]) == 0
    out = capsys.readouterr().out
    assert "'arm': order 1, group 0," in out and "triangles, mode similar" in out
    assert "3 pin(s), 1 hinge(s), 1 spring(s)" in out
