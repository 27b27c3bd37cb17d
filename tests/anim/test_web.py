"""The HTML web player: the file is self-contained, the int16 codes round-trip, and in a
real browser (headless Chromium, WebGL2 through SwiftShader) each tested frame, keys and
in-betweens the page computes (linear and on curves), matches ``puppet render --time``
(< 2 % of pixels off by more than 40 grey levels)."""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from puppet.anim.web import Q, encode_frame, fill, quantisation, script_code, script_json
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


def test_script_json_holds_no_markup_and_reads_back():
    value = {"names": ["<!--<script>", "</script>", "a&b>c", "\u2028\u2029", "</SCRIPT"]}
    text = script_json(value)
    assert not re.search(r"[<>&\u2028\u2029]", text)
    assert json.loads(text) == value


def test_the_player_holds_nothing_that_ends_its_script():
    from importlib import resources

    script_code(resources.files("puppet.anim").joinpath("player.js").read_text("utf-8"))  # raises if it does
    for bad in ("a = '</script>'", "x <!-- y", "s = '<SCRIPT>'"):
        with pytest.raises(ValueError):
            script_code(bad)


def test_fill_reads_the_template_once():
    assert fill("<title>{{title}}</title>{{meta}}", {"title": "{{meta}}", "meta": "M"}) == "<title>{{meta}}</title>M"


CHARACTER = os.path.join(ROOT, "assets", "scenes", "character.json")
#: (scene, export arguments, canvas size, number of layers)
SCENES = {"trex": (TREX, ["--to", "1"], (600, 500), 8),  # 12 fps: 13 frames
          "character": (CHARACTER, ["--to", "1", "--fps", "24"], (700, 720), 18)}  # 25 frames
needs_browser = pytest.mark.skipif(CHROMIUM is None, reason="no chromium: install Debian's chromium package "
                                                            "(.ci/run does) to test the web player in a real browser")


@pytest.fixture(scope="module", params=list(SCENES))
def page(request, tmp_path_factory):
    scene, args, size, layers = SCENES[request.param]
    out = str(tmp_path_factory.mktemp("web") / f"{request.param}.html")
    assert main(["animate", scene, "-o", out, *args]) == 0
    return SimpleNamespace(path=out, scene=scene, size=size, layers=layers)


@pytest.mark.gl
def test_page_is_self_contained_and_small(page):
    text = open(page.path, encoding="utf-8").read()
    assert os.path.getsize(page.path) < 3 << 20
    refs = re.findall(r"""(?:src|href)\s*=\s*["']?([^"'\s>]+)|url\(\s*["']?([^"')]+)""", text)
    assert all(v.startswith("data:") for pair in refs for v in pair if v), refs
    assert not re.search(r"https?://", text)
    assert text.count("data:image/png;base64,") == page.layers  # one texture a layer


@pytest.mark.gl
@pytest.mark.slow
@needs_browser
def test_browser_frames_match_puppet_render(page, tmp_path):
    refs = {}
    for t in (0.25, 7 / 12, 1.0):  # 7/12 s: in-betweens on curves (the T-rex's head, tail, arm)
        ref = str(tmp_path / f"ref{t}.png")
        assert main(["render", page.scene, "--time", str(t), "-o", ref]) == 0
        refs[t] = np.asarray(Image.open(ref).convert("RGB"))
        shot = screenshot(page.path, str(tmp_path / f"shot{t}.png"), page.size, t)
        off = grey_off(shot, refs[t])
        assert off < 0.02, (t, off)
    # the frames differ from each other, so matching the right one means something
    assert grey_off(refs[0.25], refs[7 / 12]) > 0.01
    assert grey_off(shot, refs[7 / 12]) > 0.01  # the last shot (t = 1) is not t = 7/12


DRIVE = """<script>
(async () => {
  const log = [], doc = document, wait = (ms) => new Promise((r) => setTimeout(r, ms));
  const frame = () => doc.body.dataset.frame, play = doc.getElementById("puppet-play");
  const scrub = doc.getElementById("puppet-scrub");
  while (doc.body.dataset.ready !== "1") await wait(50);
  log.push(frame());
  play.click(); await wait(500); log.push(frame(), play.textContent);
  play.click(); log.push(frame()); await wait(500); log.push(frame(), play.textContent);
  scrub.value = "3"; scrub.dispatchEvent(new Event("input")); log.push(frame());
  doc.getElementById("puppet-loop").checked = false;
  scrub.value = "9"; scrub.dispatchEvent(new Event("input"));
  play.click(); await wait(1500); log.push(frame(), play.textContent);
  location.hash = "#t=0.25"; await wait(100); log.push(frame());
  doc.body.dataset.log = log.join(",");
})();
</script>"""


@pytest.mark.gl
@pytest.mark.slow
@needs_browser
def test_controls_play_pause_scrub_loop_and_hash(tmp_path):
    out = str(tmp_path / "trex.html")
    assert main(["animate", TREX, "-o", out, "--to", "1"]) == 0  # 12 fps, 13 frames
    driven = str(tmp_path / "driven.html")
    with open(out) as f, open(driven, "w") as g:
        g.write(f.read().replace("</body>", DRIVE + "</body>"))
    dom = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                          "--enable-unsafe-swiftshader", "--virtual-time-budget=30000", "--dump-dom",
                          f"file://{driven}#t=0.5"], capture_output=True, text=True, timeout=180).stdout
    found = re.search(r'data-log="([^"]*)"', dom)  # virtual time: a budget that a loaded machine needs
    assert found, dom[-2000:]
    log = found.group(1).split(",")
    hashed, played, label, paused, still, label2, scrubbed, end, label3, rehashed = log
    assert hashed == "6"  # #t=0.5 at 12 fps
    assert int(played) > 6 and label == "Pause"  # playing advances
    assert still == paused and label2 == "Play"  # paused holds its frame
    assert scrubbed == "3"
    assert end == "12" and label3 == "Play"  # without loop it stops on the last frame
    assert rehashed == "3"  # a new #t=0.25


@pytest.mark.gl
@pytest.mark.slow
@needs_browser
def test_background_image_is_the_canvas_background(tmp_path):
    from tests.cli.outputs_helpers import make_bar

    scene = make_bar(tmp_path / "s", background=True, seconds=1.0)  # 120x40 over a picture
    out = str(tmp_path / "bar.html")
    assert main(["animate", scene, "-o", out]) == 0
    for t in (0.0, 1.0):
        ref = str(tmp_path / f"ref{t}.png")
        assert main(["render", scene, "--time", str(t), "-o", ref]) == 0
        shot = screenshot(out, str(tmp_path / f"shot{t}.png"), (120, 40), t)
        assert grey_off(shot, np.asarray(Image.open(ref).convert("RGB"))) < 0.02
    assert grey_off(shot, np.full_like(shot, 255)) > 0.5  # the picture shows, not the page's white
