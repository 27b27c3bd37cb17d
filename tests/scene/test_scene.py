"""Scenes end to end without GL: build, pose, groups, depth, links, time."""
import json

import numpy as np
import pytest

import puppet
from puppet.geom.triangulate import signed_areas
from tests.conftest import bar_image, bar_scene


def two_bars(linked: bool):
    s = bar_scene()
    s["canvas"] = [120, 80]
    s["layers"] = [{"name": "top", "image": "bar.png"}, {"name": "low", "image": "bar.png", "offset": [0, 15]}]
    s["pins"] = [{"name": "left", "layer": "top", "at": [15, 20]}, {"name": "right", "layer": "top", "at": [105, 20]},
                 {"name": "low_left", "layer": "low", "at": [15, 40], "depth": 0.5}]
    if linked:
        s["links"] = [{"layers": ["top", "low"], "segments": [[[60, 27], [80, 27]]]}]
    s["poses"] = {"bend": {"right": [100, 0]}}
    return s


def test_rest_pose_and_pins(bar):
    sc = puppet.load_scene(bar)
    (r,) = sc.layers()
    assert np.abs(r.deformed - r.rest).max() < 1e-9
    (r,) = sc.layers("bend")
    assert np.allclose(r.deformed[r.pins["right"]], [100, 5], atol=1e-9)
    assert np.allclose(r.deformed[r.pins["left"]], [15, 20], atol=1e-9)
    a0, a1 = signed_areas(r.rest, r.triangles), signed_areas(r.deformed, r.triangles)
    assert (a0 < 0).all() and (a1 < 0).all()


def test_trajectory_invariance(bar):
    sc = puppet.load_scene(bar)
    fresh = puppet.load_scene(bar).layers("bend")[0].deformed
    for t in (0.1, 0.7, 0.3):
        sc.layers(time=t)
    assert np.array_equal(sc.layers("bend")[0].deformed, fresh)


def test_time_interpolates_pin_targets(bar):
    sc = puppet.load_scene(bar)
    sc.set_inbetween("linear")  # pins on straight lines (the rigid default: tests/scene/document/test_key_edits.py)
    (r,) = sc.layers(time=0.5)
    assert np.allclose(r.deformed[r.pins["right"]], [102.5, 12.5])
    assert np.allclose(sc.layers(time=5.0)[0].deformed, sc.layers("bend")[0].deformed)


@pytest.mark.parametrize("linked", [True, False])
def test_linked_layers_move_together_unlinked_stay(make_scene, linked):
    sc = puppet.load_scene(make_scene(two_bars(linked), {"bar.png": bar_image()}))
    top, low = sc.layers("bend")
    top0, low0 = sc.layers()
    assert np.abs(top.deformed - top.rest).max() > 5
    moved = np.abs(low.deformed - low.rest).max()
    if linked:
        assert top.group == low.group == 0
        assert moved > 1.0
        # link vertices are in both layers, at equal positions, rest and deformed
        shared = [(i, j) for i in range(len(top.rest)) for j in np.where((low.rest == top.rest[i]).all(1))[0]]
        assert len(shared) >= 3
        for i, j in shared:
            assert np.array_equal(top.deformed[i], low.deformed[j])
    else:
        assert top.group != low.group
        assert moved < 1e-9


def test_depth_is_stacking_plus_pin_depth(make_scene):
    s = two_bars(True)
    s["pins"][0]["depth"] = 0.5
    s["pins"][1]["depth"] = 0.5
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))
    top, low = sc.layers()
    assert np.allclose(top.depth, 0.5) and np.allclose(low.depth, 1.5)
    s["layers"][0]["order"] = 5  # 'top' now in front of 'low'
    s["poses"]["deep"] = {"right": {"to": [105, 20], "depth": -2.0}}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}, name="b.json"))
    top, low = sc.layers("deep")
    assert top.order == 1 and low.order == 0
    right = top.depth[top.pins["right"]]
    assert right == pytest.approx(1 - 2.0)
    assert top.depth.min() >= 1 - 2.0 - 1e-9 and top.depth.max() <= 1.5 + 1e-9
    assert top.depth[top.pins["left"]] == pytest.approx(1.5)


def test_mesh_data_matches_the_interface(bar, tmp_path):
    sc = puppet.load_scene(bar)
    out = tmp_path / "m.json"
    sc.write_mesh(str(out), pose="bend")
    m = json.loads(out.read_text())
    assert m["puppet"] == 1 and m["canvas"] == [120, 40] and m["pose"] == "bend"
    (L,) = m["layers"]
    assert set(L) == {"name", "group", "order", "rest", "deformed", "triangles", "depth", "pins", "exterior"}
    n = len(L["rest"])
    assert len(L["deformed"]) == len(L["depth"]) == n and max(max(t) for t in L["triangles"]) < n
    assert L["pins"].keys() == {"left", "right"}


def test_source_layers_with_masks_and_inpainting(make_scene):
    """Two layers cut from one picture; the back one refills what the front one took."""
    img = np.full((40, 80, 4), 255, np.uint8)
    img[10:30, 5:75, :3] = (30, 160, 30)    # green body
    img[12:28, 50:70, :3] = (200, 30, 30)   # red part drawn over it
    s = {"puppet": 1, "source": "src.png",
         "layers": [{"name": "body", "mask": {"threshold": 250}, "inpaint": "telea"},
                    {"name": "part", "mask": {"rect": [50, 12, 20, 16]}}],
         "pins": [{"name": "a", "layer": "body", "at": [10, 20]}]}
    sc = puppet.load_scene(make_scene(s, {"src.png": img}))
    body, part = sc.images
    under = body.rgba[14:26, 53:67, :3].astype(int)
    assert np.abs(under - [30, 160, 30]).max() < 40, "refilled with the body's green, not the part's red"
    assert (part.rgba[12:28, 50:70, 3] == 255).all() and (part.rgba[:12, :, 3] == 0).all()
    s["layers"][0]["inpaint"] = "none"
    sc2 = puppet.load_scene(make_scene(s, {"src.png": img}, name="b.json"))
    assert (sc2.images[0].rgba[14:26, 53:67, :3] == [200, 30, 30]).all()


def test_check_summary_counts(bar):
    text = puppet.load_scene(bar).summary()
    assert "1 layer(s), 1 group(s), 2 pin(s), 1 pose(s)" in text and "vertices" in text


def test_not_applied_features_are_reported(make_scene):
    s = bar_scene()
    s["poses"]["turn"] = {"right": {"to": [105, 20], "angle": 30}}
    s["deformer"] = {"method": "mls"}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))
    assert any("angle" in n for n in sc.not_applied())
    s["deformer"] = {"method": "arap"}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}, name="b.json"))
    assert sc.not_applied() == []


@pytest.mark.parametrize("name", ["dress", "horse", "runner", "strips", "trex-cutout", "trex-layers"])
def test_bundled_scenes_load_and_rest(name):
    from tests.conftest import SCENES
    sc = puppet.load_scene(f"{SCENES}/{name}.json")
    for r in sc.layers():
        assert np.abs(r.deformed - r.rest).max() < 1e-9
