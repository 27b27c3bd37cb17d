"""Spine 4.2 JSON + atlas: the keys the format documents, a valid hull per mesh, and the
deform keys replayed (setup vertices + offsets interpolated as the runtimes do, y flipped
back) against ``puppet mesh`` within 1 px; draw-order offsets decoded as the format
defines them."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree

from puppet.anim.spine import hull_first, order_offsets, pack
from puppet.cli import main
from puppet.geom.mesh import boundary_edges
from tests.anim.test_spine_keys import replay_spine

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")


def decode_draw_order(offsets: list[dict] | None, slots: list[str]) -> list[int]:
    """The draw order (slot indices, back first) a key's ``offsets`` give, per the format:
    listed slots (in setup order) move by their offset, the others keep their relative
    order in the positions left."""
    n = len(slots)
    if not offsets:
        return list(range(n))
    order = [-1] * n
    listed = {slots.index(o["slot"]): o["offset"] for o in offsets}
    assert list(listed) == sorted(listed), "offsets must be in setup order"
    for s, off in listed.items():
        order[s + off] = s
    rest = iter(s for s in range(n) if s not in listed)
    return [s if s >= 0 else next(rest) for s in order]


@pytest.mark.parametrize("seed", range(20))
def test_draw_order_offsets_decode_to_the_order(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 9))
    order = rng.permutation(n).tolist()
    names = [f"s{i}" for i in range(n)]
    assert decode_draw_order(order_offsets(order, names), names) == order
    assert order_offsets(list(range(n)), names) is None


def test_hull_first_square_with_centre():
    # 4 corners + centre (index 2), 4 triangles around it
    tri = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 0, 2]])
    perm, hull = hull_first(tri, 5)
    assert hull == 4 and perm[4] == 2 and sorted(perm[:4]) == [0, 1, 3, 4]
    loop = perm[:4].tolist()
    edges = {tuple(e) for e in boundary_edges(tri).tolist()}
    assert all((loop[k], loop[(k + 1) % 4]) in edges for k in range(4))


def test_pack_keeps_boxes_apart_and_on_pages():
    sizes = [(100, 50), (30, 80), (200, 10), (64, 64), (90, 90)]
    place = pack(sizes, side=256, pad=2)
    boxes = [(p, x, y, x + w, y + h) for (p, x, y), (w, h) in zip(place, sizes)]
    for i, a in enumerate(boxes):
        assert a[3] <= 254 and a[4] <= 254 and a[1] >= 2 and a[2] >= 2
        for b in boxes[i + 1:]:
            if a[0] == b[0]:
                assert a[3] + 2 <= b[1] or b[3] + 2 <= a[1] or a[4] + 2 <= b[2] or b[4] + 2 <= a[2]
    with pytest.raises(ValueError):
        pack([(300, 10)], side=256)


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    d = tmp_path_factory.mktemp("spine")
    out = str(d / "trex.json")
    assert main(["animate", TREX, "-o", out, "--format", "spine", "--to", "1"]) == 0
    with open(out) as f:
        return d, json.load(f)


def puppet_mesh(tmp, *args) -> dict:
    out = str(tmp / "mesh.json")
    assert main(["mesh", TREX, *args, "-o", out]) == 0
    with open(out) as f:
        return json.load(f)


def test_documented_keys(export):
    d, doc = export
    assert sorted(os.listdir(d)) == ["trex.atlas", "trex.json", "trex.png"]
    sk = doc["skeleton"]
    assert sk["spine"].startswith("4.2.") and sk["fps"] == 12 and {"x", "y", "width", "height", "hash"} <= set(sk)
    assert doc["bones"] == [{"name": "root"}]
    names = ["body", "tail", "tophead", "bottomhead", "leftleg", "rightleg", "bottomarm", "toparm"]
    assert [s["name"] for s in doc["slots"]] == names  # stacking order
    assert all(s["bone"] == "root" and s["attachment"] == s["name"] for s in doc["slots"])
    assert [s["name"] for s in doc["skins"]] == ["default"]
    atts = doc["skins"][0]["attachments"]
    assert list(atts) == names and all(list(a) == [n] for n, a in atts.items())  # one mesh per layer
    assert set(doc["animations"]) == {"animation", "roar", "wave", "step", "swish", "tuck"}
    for name, anim in doc["animations"].items():
        assert set(anim) <= {"attachments", "drawOrder"}
        for slot, by_att in anim.get("attachments", {"default": {}})["default"].items():
            (att, tl), = by_att.items()
            assert att == slot and list(tl) == ["deform"]
            keys = tl["deform"]
            times = [k["time"] for k in keys]
            if name == "animation":  # the scene's keys (0, 0.5, 1 s) and what interpolation needs
                assert {0.0, 0.5, 1.0} <= set(times) and len(keys) <= 13 and times == sorted(times)
            else:
                assert times == [0.0]
            assert all(set(k) <= {"time", "vertices", "curve"} for k in keys)
            assert all(len(k["curve"]) == 4 and keys[i]["time"] <= k["curve"][0] <= k["curve"][2] <= keys[i + 1]["time"]
                       for i, k in enumerate(keys) if "curve" in k)  # handles' times within the span
            n = len(atts[slot][att]["vertices"])
            assert all(len(k.get("vertices", [0] * n)) == n for k in keys)


def test_meshes_are_valid_with_the_hull_first(export):
    _, doc = export
    for slot, by_att in doc["skins"][0]["attachments"].items():
        m = by_att[slot]
        assert m["type"] == "mesh"
        n = len(m["uvs"]) // 2
        assert len(m["uvs"]) == len(m["vertices"]) == 2 * n  # unweighted
        uv = np.reshape(m["uvs"], (-1, 2))
        assert uv.min() >= 0 and uv.max() <= 1
        tri = np.reshape(m["triangles"], (-1, 3))
        assert tri.min() >= 0 and tri.max() < n and len(np.unique(tri)) == n
        h = m["hull"]
        assert 3 <= h <= n
        loop = list(range(h))
        bnd = {tuple(sorted(e)) for e in boundary_edges(tri).tolist()}
        hull = {tuple(sorted((loop[k], loop[(k + 1) % h]))) for k in range(h)}
        assert hull <= bnd  # the first `hull` vertices go round the outline, in order
        edges = np.asarray(m["edges"])
        assert len(edges) % 2 == 0 and np.all(edges % 2 == 0) and edges.max() < 2 * n
        assert {tuple(sorted((a // 2, b // 2))) for a, b in edges.reshape(-1, 2)} >= hull
        assert m["width"] > 0 and m["height"] > 0


def replay(doc, anim: str, t: float, W: int, H: int) -> dict[str, np.ndarray]:
    """Canvas positions (n, 2) per slot at time t: the deform timeline interpolated as the
    Spine runtimes do (:func:`tests.anim.test_spine_keys.replay_spine`), Spine y up mapped
    back to canvas y down."""
    out = {}
    atts = doc["skins"][0]["attachments"]
    timelines = doc["animations"][anim].get("attachments", {}).get("default", {})
    for slot, by_att in atts.items():
        (att, m), = by_att.items()
        v = np.asarray(m["vertices"], float)
        if slot in timelines:
            v = replay_spine(timelines[slot][att]["deform"], v, t)
        xy = v.reshape(-1, 2)
        out[slot] = np.stack([xy[:, 0] + W / 2, H - xy[:, 1]], axis=1), np.reshape(m["vertices"], (-1, 2))
    return out


@pytest.mark.parametrize("anim,t,args", [("animation", 0.0, ["--time", "0"]), ("animation", 0.5, ["--time", "0.5"]),
                                         ("animation", 11 / 12, ["--time", str(11 / 12)]),
                                         ("tuck", 0.0, ["--pose", "tuck"]), ("roar", 0.0, ["--pose", "roar"])])
def test_replayed_deform_keys_match_puppet_mesh(export, tmp_path, anim, t, args):
    _, doc = export
    want = puppet_mesh(tmp_path, *args)
    W, H = want["canvas"]
    got = replay(doc, anim, t, W, H)
    moved = 0.0
    for L in want["layers"]:
        xy, setup = got[L["name"]]
        rest = np.asarray(L["rest"])
        setup_canvas = np.stack([setup[:, 0] + W / 2, H - setup[:, 1]], axis=1)
        dist, idx = cKDTree(rest).query(setup_canvas)
        assert dist.max() < 0.01 and len(np.unique(idx)) == len(rest)  # setup = rest mesh, y flipped
        err = np.linalg.norm(xy - np.asarray(L["deformed"])[idx], axis=1)
        assert err.max() < 1.0, (L["name"], err.max())
        moved = max(moved, np.linalg.norm(np.asarray(L["deformed"]) - rest, axis=1).max())
    if (anim, t) != ("animation", 0.0):  # the first key is the rest pose
        assert moved > 5  # the pose does move vertices: the comparison can fail


def test_draw_order_follows_mean_depth(export, tmp_path):
    _, doc = export
    slots = [s["name"] for s in doc["slots"]]
    (key,) = doc["animations"]["tuck"]["drawOrder"]  # the tuck pose pushes the arm behind
    order = decode_draw_order(key.get("offsets"), slots)
    want = puppet_mesh(tmp_path, "--pose", "tuck")
    means = {L["name"]: np.mean(L["depth"]) for L in want["layers"]}
    assert order != list(range(len(slots)))
    assert [means[slots[s]] for s in order] == sorted(means[slots[s]] for s in order)
    assert "drawOrder" not in doc["animations"]["roar"]


def test_atlas_regions_hold_the_layer_pixels(export):
    d, doc = export
    text = open(d / "trex.atlas").read().splitlines()
    assert text[0] == "trex.png" and text[1].strip().startswith("size:")
    page = np.asarray(Image.open(d / "trex.png").convert("RGBA"))
    pw, ph = (int(v) for v in text[1].split(":")[1].split(","))
    assert page.shape[:2] == (ph, pw)
    regions = {}
    for i, line in enumerate(text):
        if line.strip().startswith("bounds:"):
            regions[text[i - 1]] = [int(v) for v in line.split(":")[1].split(",")]
    atts = doc["skins"][0]["attachments"]
    assert set(regions) == set(atts)
    for name, (x, y, w, h) in regions.items():
        m = atts[name][name]
        assert (w, h) == (m["width"], m["height"]) and x + w <= pw and y + h <= ph
        assert page[y:y + h, x:x + w, 3].max() == 255


def test_user_errors(tmp_path, capsys):
    assert main(["animate", TREX, "-o", str(tmp_path / "a.json")]) == 2
    assert "--format spine" in capsys.readouterr().err
    assert main(["animate", TREX, "-o", str(tmp_path / "a.spine.json"), "--wireframe"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("puppet: error: --wireframe") and err.count("\n") == 1
    assert main(["animate", TREX, "-o", str(tmp_path / "a.html"), "--format", "spine"]) == 2
    assert os.listdir(tmp_path) == []


def test_a_layer_larger_than_an_atlas_page_is_a_user_error(tmp_path, capsys, monkeypatch):
    import puppet.anim.spine as spine

    monkeypatch.setattr(spine, "PAGE_SIDE", 128)  # the T-rex body is 223x228
    out = tmp_path / "a.spine.json"
    assert main(["animate", TREX, "-o", str(out), "--to", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("puppet: error:") and "atlas pages are at most 128 px" in err and err.count("\n") == 1
    assert os.listdir(tmp_path) == []
