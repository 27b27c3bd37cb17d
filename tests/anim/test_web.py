"""The HTML web player: the file is self-contained, the int16 codes round-trip, and in a
real browser (headless Chromium, WebGL2 through SwiftShader) each tested frame matches
``puppet render --time`` (< 2 % of pixels off by more than 40 grey levels)."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from puppet.anim.web import Q, encode_frame, quantisation
from puppet.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def screenshot(page: str, out: str, size: tuple[int, int], t: float) -> np.ndarray:
    """The canvas region (h, w, 3) of ``page#t=T`` in headless Chromium."""
    w, h = size
    cmd = [CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
           "--hide-scrollbars", f"--window-size={w},{h + 60}", "--virtual-time-budget=8000",
           f"--screenshot={out}", f"file://{os.path.abspath(page)}#t={t}"]
    subprocess.run(cmd, check=True, timeout=120, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return np.asarray(Image.open(out).convert("RGB"))[:h, :w]


def grey_off(a: np.ndarray, b: np.ndarray, levels: int = 40) -> float:
    """Fraction of pixels whose largest channel difference exceeds ``levels``."""
    return float(np.mean(np.abs(a.astype(int) - b.astype(int)).max(axis=2) > levels))


def test_codes_round_trip_within_half_a_step():
    quant, dstep = quantisation((700, 720), 18)
    rng = np.random.default_rng(0)
    xy = rng.uniform(-700, 1400, (50, 2))
    d = rng.uniform(-40, 40, 50)
    layers = [SimpleNamespace(deformed=xy[:20], depth=d[:20]), SimpleNamespace(deformed=xy[20:], depth=d[20:])]
    q = np.frombuffer(encode_frame(layers, quant, dstep), "<i2").astype(float)
    assert len(q) == 150 and len(q) * 2 % 3 == 0  # 6 bytes a vertex: base64 without padding
    back = q[:100].reshape(-1, 2) * quant[:2] + quant[2:]
    assert np.abs(back - xy).max() <= max(quant[:2]) / 2 + 1e-9
    assert max(quant[:2]) < 0.033  # 3 * 720 / 65534 px a step
    assert np.abs(q[100:] * dstep - d).max() <= dstep / 2 + 1e-12 and dstep <= 1 / 256


def test_codes_clamp_far_outside_the_canvas():
    quant, dstep = quantisation((100, 100), 1)
    layers = [SimpleNamespace(deformed=np.array([[1e6, -1e6]]), depth=np.array([1e9]))]
    q = np.frombuffer(encode_frame(layers, quant, dstep), "<i2")
    assert q.tolist() == [Q, -Q, Q]


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("web") / "trex.html")
    assert main(["animate", TREX, "-o", out, "--to", "1"]) == 0
    return out


@pytest.mark.gl
def test_page_is_self_contained_and_small(page):
    text = open(page, encoding="ascii").read()
    assert os.path.getsize(page) < 3 << 20
    refs = re.findall(r"""(?:src|href)\s*=\s*["']?([^"'\s>]+)|url\(\s*["']?([^"')]+)""", text)
    assert all(v.startswith("data:") for pair in refs for v in pair if v), refs
    assert not re.search(r"https?://", text)
    assert text.count("data:image/png;base64,") == 8  # one texture a layer


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium: install Debian's chromium package (.ci/run does) "
                                                "to test the web player in a real browser")
def test_browser_frames_match_puppet_render(page, tmp_path):
    size = (600, 500)
    refs = {}
    for t in (0.0, 0.25, 0.5, 1.0):
        ref = str(tmp_path / f"ref{t}.png")
        assert main(["render", TREX, "--time", str(t), "-o", ref]) == 0
        refs[t] = np.asarray(Image.open(ref).convert("RGB"))
        shot = screenshot(page, str(tmp_path / f"shot{t}.png"), size, t)
        off = grey_off(shot, refs[t])
        assert off < 0.02, (t, off)
    # the frames differ from each other, so matching the right one means something
    assert grey_off(refs[0.0], refs[0.5]) > 0.02
    assert grey_off(shot, refs[0.5]) > 0.02  # the last shot (t = 1) is not t = 0.5
