"""glTF 2.0 binary: loaded back with pygltflib; one mesh per layer, a morph target per
frame, and rest + target i (y flipped back) within 1 px of ``puppet mesh --time``."""
from __future__ import annotations

import io
import json
import os

import numpy as np
import pytest
from PIL import Image

from puppet.cli import main

pygltflib = pytest.importorskip("pygltflib", reason="pygltflib (a test dependency) reads the .glb back")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
DTYPES = {5126: np.float32, 5125: np.uint32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}


def read(g, blob: bytes, index: int) -> np.ndarray:
    acc = g.accessors[index]
    view = g.bufferViews[acc.bufferView]
    a = np.frombuffer(blob, DTYPES[acc.componentType], acc.count * WIDTH[acc.type],
                      view.byteOffset + (acc.byteOffset or 0))
    return a.reshape(acc.count, WIDTH[acc.type])


@pytest.fixture(scope="module")
def glb(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("glb") / "trex.glb")
    assert main(["animate", TREX, "-o", out, "--to", "1"]) == 0  # 13 frames at 12 fps
    g = pygltflib.GLTF2().load_binary(out)
    return g, g.binary_blob()


def test_structure(glb):
    g, blob = glb
    assert g.asset.version == "2.0"
    names = ["body", "tail", "tophead", "bottomhead", "leftleg", "rightleg", "bottomarm", "toparm"]
    assert [m.name for m in g.meshes] == names and len(g.images) == 8
    root = g.nodes[g.scenes[0].nodes[0]]
    assert [g.nodes[c].name for c in root.children] == names
    (anim,) = g.animations
    (sampler,) = anim.samplers
    times = read(g, blob, sampler.input)[:, 0]
    assert np.allclose(times, np.arange(13) / 12)
    w = read(g, blob, sampler.output).reshape(13, 13)
    assert np.array_equal(w, np.eye(13)) and sampler.interpolation == "LINEAR"
    assert sorted(c.target.node for c in anim.channels) == list(range(8))
    for m in g.meshes:
        (p,) = m.primitives
        assert len(p.targets) == 13 and len(m.weights) == 13
        tri = read(g, blob, p.indices).reshape(-1, 3)
        n = g.accessors[p.attributes.POSITION].count
        assert tri.max() < n and g.accessors[p.attributes.TEXCOORD_0].count == n
        for t in p.targets:  # min/max are required on POSITION accessors
            acc = g.accessors[t["POSITION"]]
            a = read(g, blob, t["POSITION"])
            assert np.allclose(acc.min, a.min(axis=0)) and np.allclose(acc.max, a.max(axis=0))
    png = g.bufferViews[g.images[0].bufferView]
    im = Image.open(io.BytesIO(blob[png.byteOffset:png.byteOffset + png.byteLength]))
    assert im.mode == "RGBA"


@pytest.mark.parametrize("frame", [0, 6, 11])
def test_morph_targets_replay_puppet_mesh(glb, tmp_path, frame):
    g, blob = glb
    out = str(tmp_path / "m.json")
    assert main(["mesh", TREX, "--time", str(frame / 12), "-o", out]) == 0
    want = json.load(open(out))
    W, H = want["canvas"]
    moved = 0.0
    for m, L in zip(g.meshes, want["layers"]):
        (p,) = m.primitives
        pos = read(g, blob, p.attributes.POSITION) + read(g, blob, p.targets[frame]["POSITION"])
        xy = np.stack([pos[:, 0] + W / 2, H - pos[:, 1]], axis=1)
        assert np.abs(xy - np.asarray(L["deformed"])).max() < 1.0
        assert np.abs(pos[:, 2] - np.asarray(L["depth"])).max() < 1e-3  # z is the per-vertex depth
        moved = max(moved, np.abs(np.asarray(L["deformed"]) - np.asarray(L["rest"])).max())
    assert frame == 0 or moved > 5


def test_too_many_frames_is_refused_before_writing(tmp_path, capsys):
    assert main(["animate", TREX, "-o", str(tmp_path / "b.glb"), "--fps", "240", "--to", "5"]) == 2
    err = capsys.readouterr().err
    assert "at most 1000 frames" in err and not (tmp_path / "b.glb").exists()


THREE = os.environ.get("PUPPET_THREE_JS")  # a three.js package folder (npm install three), e.g. node_modules/three
VIEW = """<!DOCTYPE html><html><body style="margin:0;background:#fff">
<script type="importmap">{"imports": {"three": "file://THREE/build/three.module.js",
 "three/addons/": "file://THREE/examples/jsm/"}}</script>
<script type="module">
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
const renderer = new THREE.WebGLRenderer({antialias: false, preserveDrawingBuffer: true});
renderer.setSize(WIDTH, HEIGHT);
renderer.setClearColor(0xffffff, 1);
document.body.appendChild(renderer.domElement);
const t = parseFloat(location.hash.slice(3));
new GLTFLoader().load("trex.glb", (g) => {
  const mixer = new THREE.AnimationMixer(g.scene);
  mixer.clipAction(g.animations[0]).play();
  mixer.setTime(t);
  renderer.render(g.scene, g.cameras[0]);
});
</script></body></html>"""


@pytest.mark.gl
@pytest.mark.skipif(not THREE, reason="set PUPPET_THREE_JS to a three.js package folder (npm install three) "
                                      "to render the .glb in a real glTF viewer")
def test_three_js_renders_it_like_puppet(tmp_path):
    from tests.anim.test_web import CHROMIUM, grey_off

    if CHROMIUM is None:
        pytest.skip("no chromium")
    import subprocess

    assert main(["animate", TREX, "-o", str(tmp_path / "trex.glb"), "--to", "1"]) == 0
    page = tmp_path / "view.html"
    page.write_text(VIEW.replace("THREE/", os.path.abspath(THREE) + "/").replace("WIDTH", "600")
                    .replace("HEIGHT", "500"))
    for t in (0.25, 0.5):  # on frames (12 fps) and between keys of the scene
        shot, ref = tmp_path / f"shot{t}.png", tmp_path / f"ref{t}.png"
        subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                        "--enable-unsafe-swiftshader", "--allow-file-access-from-files", "--hide-scrollbars",
                        "--window-size=600,500", "--virtual-time-budget=8000", f"--screenshot={shot}",
                        f"file://{page}#t={t}"], check=True, timeout=120, capture_output=True)
        assert main(["render", TREX, "--time", str(t), "-o", str(ref)]) == 0
        a = np.asarray(Image.open(shot).convert("RGB"))[:500, :600]
        assert grey_off(a, np.asarray(Image.open(ref).convert("RGB"))) < 0.02, t
