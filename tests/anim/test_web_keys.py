"""The web player's frames stored as keys: the page's records decoded and its in-betweens
computed here as :file:`player.js` computes them (the curve as the Spine runtimes read
it, :func:`tests.anim.test_spine_keys.runtime_percent`), against puppet's solved frames:
within 1 px (depths within ``DEPTH_TOLERANCE``) by default, and with ``--tolerance 0``
the very int16 codes the page stored for every frame before keys were reduced; and the
frames the page itself computes in a real browser, against puppet's."""
from __future__ import annotations

import base64
import json
import math
import os
import re
import struct

import numpy as np
import subprocess

import pytest

import puppet.anim.web as web
from puppet.cli import main
from tests.anim.test_spine_keys import runtime_percent
from tests.anim.test_web import CHROMIUM, needs_browser

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")


def decode(path: str) -> tuple[dict, np.ndarray, int, list[list[int]]]:
    """(meta, every frame's int16 codes (count, 3 x vertices), number of key records,
    each layer's key frames)."""
    text = open(path, encoding="utf-8").read()
    meta = json.loads(re.search(r'<script id="puppet-meta"[^>]*>(.*?)</script>', text, re.S).group(1))
    b64 = re.search(r'<script id="puppet-frames"[^>]*>(.*?)</script>', text, re.S).group(1)
    raw = base64.b64decode("".join(b64.split()))
    keys = [[] for _ in meta["layers"]]
    o = 0
    while o < len(raw):
        li, f, *curve = struct.unpack_from("<ii4f", raw, o)
        n = meta["layers"][li]["n"]
        q = np.frombuffer(raw, "<i2", 3 * n, o + 24).astype(np.float64)
        keys[li].append((f, None if math.isnan(curve[0]) else curve, q))
        o += 24 + 6 * n
    N, NV, fps = meta["count"], meta["vertices"], meta["fps"]
    out = np.zeros((N, 3 * NV), np.int64)
    for L, ks in zip(meta["layers"], keys):
        if not L["opaque"]:  # the page draws nothing of it: no keys
            assert not ks
            continue
        assert [k[0] for k in ks] == sorted({k[0] for k in ks}) and ks[0][0] == 0 and ks[-1][0] == N - 1
        b, n = L["base"], L["n"]
        for (fa, curve, qa), (fb, _, qb) in zip(ks, ks[1:] + ks[-1:]):
            for f in range(fa, fb if fb > fa else fa + 1):
                p = 0.0 if f == fa else runtime_percent({"curve": curve} if curve else {}, fa / fps, fb / fps, f / fps)
                v = np.floor(qa + p * (qb - qa) + 0.5)  # JavaScript's Math.round
                out[f, 2 * b:2 * (b + n)] = v[:2 * n]
                out[f, 2 * NV + b:2 * NV + b + n] = v[2 * n:]
    return meta, out, sum(map(len, keys)), [[k[0] for k in ks] for ks in keys]


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The T-rex's whole animation (25 frames) as pages with the default tolerance and
    with 0, and the solved frames as the export was handed them."""
    d = tmp_path_factory.mktemp("webkeys")
    frames = []
    add = web.HtmlSink.add
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(web.HtmlSink, "add", lambda self, layers: (frames.append(layers), add(self, layers))[1])
        for name, tol in (("keys", []), ("all", ["--tolerance", "0"])):
            assert main(["animate", TREX, "-o", str(d / f"{name}.html"), *tol]) == 0
    return {name: str(d / f"{name}.html") for name in ("keys", "all")}, frames[:25], frames[25:]


def test_tolerance_zero_keeps_the_codes_of_every_frame(pages):
    paths, _, frames = pages
    meta, codes, records, _ = decode(paths["all"])
    assert len(frames) == meta["count"] == 25 and records == 25 * len(meta["layers"])
    for f, layers in enumerate(frames):  # the codes the page stored before keys were reduced
        assert np.array_equal(codes[f], np.frombuffer(web.encode_frame(layers, meta["quant"], meta["depthStep"]),
                                                      "<i2")), f


def test_keys_replay_every_frame_within_a_pixel(pages):
    paths, frames, _ = pages
    meta, codes, records, _ = decode(paths["keys"])
    sx, sy, cx, cy = meta["quant"]
    NV = meta["vertices"]
    worst, moved = 0.0, 0.0
    for f, layers in enumerate(frames):
        xy = np.concatenate([np.asarray(r.deformed) for r in layers])
        d = np.concatenate([np.asarray(r.depth) for r in layers])
        got = codes[f, :2 * NV].reshape(-1, 2) * (sx, sy) + (cx, cy)
        worst = max(worst, float(np.linalg.norm(got - xy, axis=1).max()))
        assert np.abs(codes[f, 2 * NV:] * meta["depthStep"] - d).max() <= web.DEPTH_TOLERANCE + meta["depthStep"]
        moved = max(moved, float(np.linalg.norm(xy - np.concatenate([r.rest for r in layers]), axis=1).max()))
    assert worst < 1.0 and moved > 20  # the frames move: the comparison can fail
    assert records <= 0.5 * 25 * len(meta["layers"])  # fewer than half of the frames stored
    assert os.path.getsize(paths["keys"]) < 0.6 * os.path.getsize(paths["all"])


def test_a_long_span_between_scene_keys_is_cut(tmp_path, monkeypatch):
    monkeypatch.setattr(web, "SPAN", 4)  # a key at least every 4 frames
    out = str(tmp_path / "t.html")
    assert main(["animate", TREX, "-o", out, "--to", "0.5"]) == 0  # frames 0..6: keys 0 and 6
    _, _, _, frames = decode(out)
    assert all({0, 4, 6} <= set(f) for f in frames)


DUMP = """<script>
(async () => {
  const wait = (ms) => new Promise((r) => setTimeout(r, ms));
  while (document.body.dataset.ready !== "1") await wait(50);
  const codes = document.getElementById("puppet-canvas").puppetFrames;
  const bytes = new Uint8Array(codes.buffer, codes.byteOffset, codes.byteLength);
  let s = "";
  for (let i = 0; i < bytes.length; i += 8192) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 8192));
  document.body.dataset.codes = btoa(s);
})();
</script>"""


@pytest.mark.gl
@pytest.mark.slow
@needs_browser
def test_the_browsers_frames_are_puppets_within_a_pixel(pages, tmp_path):
    paths, frames, _ = pages
    driven = str(tmp_path / "driven.html")
    with open(paths["keys"], encoding="utf-8") as f, open(driven, "w", encoding="utf-8") as g:
        g.write(f.read().replace("</body>", DUMP + "</body>"))
    dom = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                          "--enable-unsafe-swiftshader", "--virtual-time-budget=30000", "--dump-dom",
                          f"file://{driven}#t=0"], capture_output=True, text=True, timeout=180).stdout
    found = re.search(r'data-codes="([^"]*)"', dom)
    assert found, dom[-2000:]
    meta, mine, _, _ = decode(paths["keys"])
    codes = np.frombuffer(base64.b64decode(found.group(1)), "<i2").reshape(meta["count"], -1).astype(np.int64)
    off = int(np.abs(codes - mine).max())
    assert off <= 1, off  # as computed here (a rounding apart at most)
    sx, sy, cx, cy = meta["quant"]
    NV = meta["vertices"]
    for f, layers in enumerate(frames):
        xy = np.concatenate([np.asarray(r.deformed) for r in layers])
        err = np.linalg.norm(codes[f, :2 * NV].reshape(-1, 2) * (sx, sy) + (cx, cy) - xy, axis=1).max()
        assert err < 1.0, (f, err)


@pytest.mark.slow
def test_the_character_clip_meets_the_size_targets(tmp_path):
    """Issue 32's targets on its 49-frame character clip: the web player <= 2 MB (4.0 MB
    with a key every frame), Spine <= 1 MB with lighter meshes (still within 1 px:
    ``--simplify 0.5 --tolerance 0.5``; 5.8 MB with a key every frame)."""
    from tests.anim.character_clip import character_clip

    scene = character_clip(str(tmp_path))
    html, sp = str(tmp_path / "c.html"), str(tmp_path / "c.spine.json")
    assert main(["animate", scene, "-o", html]) == 0
    assert main(["animate", scene, "-o", sp, "--simplify", "0.5", "--tolerance", "0.5"]) == 0
    meta, _, records, _ = decode(html)
    assert meta["count"] == 49 and records < 49 * len(meta["layers"]) / 3
    assert os.path.getsize(html) <= 2_000_000 and os.path.getsize(sp) <= 1_000_000
