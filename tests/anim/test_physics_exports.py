"""Secondary motion is baked into every export (issue 35 item 2): Spine deform keys and
glTF morph targets replay the swinging chain as ``puppet mesh --time`` has it, and the web
player and the GIF differ from the same scene without physics."""
from __future__ import annotations

import json

import numpy as np
import pygltflib
import pytest
from PIL import Image

from puppet.cli import main
from tests.anim.test_gltf import read
from tests.anim.test_spine import replay
from tests.conftest import bar_image
from tests.scene.time.test_physics import CHAIN, tail_scene

T = 0.75  # a frame of the swing (9 / 12 s)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """The swinging tail with and without its chain, 12 fps, cut to 1.5 s."""
    d = tmp_path_factory.mktemp("tail")
    Image.fromarray(bar_image(220, 40, (5, 5, 215, 25))).save(d / "tail.png")
    out = {}
    for name, physics in (("swing", {"chains": [CHAIN]}), ("still", None)):
        s = tail_scene(physics)
        s["animation"]["fps"] = 12
        s["animation"]["keys"][-1]["time"] = 1.5
        (d / f"{name}.json").write_text(json.dumps(s))
        out[name] = str(d / f"{name}.json")
    return d, out


def mesh_at(scene: str, tmp, t: float) -> dict:
    out = str(tmp / "mesh.json")
    assert main(["mesh", scene, "--time", str(t), "-o", out]) == 0
    return json.loads(open(out).read())


def test_spine_and_gltf_replay_the_swing(scenes, tmp_path):
    d, sc = scenes
    want, still = mesh_at(sc["swing"], tmp_path, T), mesh_at(sc["still"], tmp_path, T)
    (L,), (S,) = want["layers"], still["layers"]
    tip = L["pins"]["t3"]
    assert np.hypot(*np.subtract(L["deformed"][tip], S["deformed"][tip])) > 3.0  # the chain does swing
    W, H = want["canvas"]
    assert main(["animate", sc["swing"], "-o", str(tmp_path / "a.spine.json")]) == 0
    doc = json.loads((tmp_path / "a.spine.json").read_text())
    xy, _ = replay(doc, "animation", T, W, H)["tail"]
    got = xy[np.argmin(np.hypot(*(np.asarray(L["rest"])[tip] - np.asarray(_setup(doc, W, H))).T))]
    assert np.hypot(*(got - L["deformed"][tip])) < 1.0
    assert main(["animate", sc["swing"], "-o", str(tmp_path / "a.glb")]) == 0
    g = pygltflib.GLTF2().load_binary(str(tmp_path / "a.glb"))
    blob = g.binary_blob()
    (p,) = g.meshes[0].primitives
    pos = read(g, blob, p.attributes.POSITION) + read(g, blob, p.targets[round(T * 12)]["POSITION"])
    gl = np.stack([pos[:, 0] + W / 2, H - pos[:, 1]], axis=1)
    assert np.abs(gl - np.asarray(L["deformed"])).max() < 1.0


def _setup(doc: dict, W: int, H: int) -> np.ndarray:
    (m,) = doc["skins"][0]["attachments"]["tail"].values()
    v = np.reshape(m["vertices"], (-1, 2))
    return np.stack([v[:, 0] + W / 2, H - v[:, 1]], axis=1)


@pytest.mark.gl
def test_the_web_player_and_the_gif_carry_the_swing(scenes, tmp_path):
    d, sc = scenes
    for fmt in ("html", "gif"):
        outs = []
        for name in ("swing", "still"):
            out = tmp_path / f"{name}.{fmt}"
            assert main(["animate", sc[name], "-o", str(out)]) == 0
            outs.append(out)
        if fmt == "gif":
            a, b = (Image.open(o) for o in outs)
            a.seek(round(T * 12))
            b.seek(round(T * 12))
            diff = np.abs(np.asarray(a.convert("RGB"), int) - np.asarray(b.convert("RGB"), int)).max(axis=2)
            assert (diff > 60).sum() > 100  # the tail's end is elsewhere in that frame
        else:
            assert outs[0].read_bytes() != outs[1].read_bytes()
