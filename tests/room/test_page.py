"""The dressing room's page in a real browser (headless Chromium, as the web player's
tests): outfits opened from ``#outfit=`` draw what ``puppet render`` draws of the same
garments composited in draw order (< 2 % of pixels off by more than 40 grey levels),
and clicks and drags dispatched in the page put garments on and take them off."""
from __future__ import annotations

import base64
import dataclasses
import io
import os
import re
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from puppet.cli import main
from tests.anim.test_web import CHROMIUM, grey_off, needs_browser
from tests.room import art
from tests.room.art import GARMENTS, SIZE, room_files

pytestmark = [pytest.mark.gl, pytest.mark.slow, needs_browser]


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    from puppet.room.model import load_room

    folder = str(tmp_path_factory.mktemp("room"))
    body, files = room_files(folder, ("shirt", "jeans", "hat", "vest"))
    out = os.path.join(folder, "room.html")
    assert main(["dressroom", body, *files, "-o", out]) == 0
    return SimpleNamespace(path=out, folder=folder, model=load_room(body, files))


def browse(page: str, hash_: str, script: str, size=(800, 600), extra=()) -> dict[str, str]:
    """The ``data-*`` attributes of the body after ``script`` (appended to the page) ran
    in headless Chromium opened at ``page#hash_``."""
    driven = page.replace(".html", "-driven.html")
    with open(page, encoding="utf-8") as f, open(driven, "w", encoding="utf-8") as g:
        g.write(f.read().replace("</body>", f"<script>\n{WAIT}{script}\n</script></body>"))
    cmd = [CHROMIUM, "--headless=new", "--no-sandbox", "--hide-scrollbars", f"--window-size={size[0]},{size[1]}",
           "--virtual-time-budget=30000", *extra, f"file://{driven}#{hash_}"]
    dom = subprocess.run(cmd + ["--dump-dom"], capture_output=True, text=True, timeout=180).stdout
    body = re.search(r"<body([^>]*)>", dom)
    assert body, dom[-2000:]
    return dict(re.findall(r'data-([\w-]+)="([^"]*)"', body.group(1)))


def png(uri: str) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(uri.split(",", 1)[1]))).convert("RGBA"))


WAIT = """const doc = document, wait = (ms) => new Promise((r) => setTimeout(r, ms));
const draws = () => +(doc.body.dataset.draws || 0);
async function ready() { while (doc.body.dataset.ready !== "1") await wait(20); }
async function after(n) { while (draws() <= n) await wait(20); }
const shot = () => doc.getElementById("room-canvas").toDataURL();
"""

OUTFITS = """(async () => {
  await ready();
  const out = {o0: shot(), w0: doc.body.dataset.outfit};
  const hashes = ["#outfit=vest,cap,jeans", "#outfit=shirt,jeans&tuck=1"];
  for (let k = 0; k < hashes.length; k++) {
    const n = draws(); location.hash = hashes[k]; await after(n);
    out["o" + (k + 1)] = shot(); out["w" + (k + 1)] = doc.body.dataset.outfit;
  }
  out.tuck = String(doc.getElementById("room-tuck").checked);
  Object.assign(doc.body.dataset, out);
})();"""


def tucked_reference(room) -> np.ndarray:
    """shirt and jeans, the shirt tucked in: its pixels hidden where its depth is below the
    jeans', where they show and below their first row in each column (against their depth
    on that row)."""
    from puppet.room.model import wear

    jeans, shirt = (next(g for g in room.garments if g.name == n) for n in ("jeans", "shirt"))
    jeans_depth, shirt_depth = jeans.depth_on_canvas(room.canvas), shirt.depth_on_canvas(room.canvas)
    h, w = jeans_depth.shape
    shows = jeans.on_canvas(room.canvas)[..., 3] > 0
    edge = np.where(shows.any(axis=0), shows.argmax(axis=0), h)
    bottom = np.where(shows, jeans_depth, jeans_depth[np.minimum(edge, h - 1), np.arange(w)][None, :])
    hide = (np.arange(h)[:, None] >= edge[None, :]) & (shirt_depth < bottom)
    rgba = shirt.on_canvas(room.canvas)
    rgba[hide, 3] = 0
    garments = [dataclasses.replace(g, rgba=rgba, at=(0, 0)) if g is shirt else g for g in room.garments]
    return wear(dataclasses.replace(room, garments=garments), {"shirt", "jeans"})


#: A black cover over the page until it has drawn: a screenshot taken before (virtual time
#: can run out while pictures decode on another thread) shows it, and is taken again.
COVER = """const cover = document.createElement("div");
cover.style.cssText = "position: fixed; inset: 0; z-index: 99; background: #000";
document.body.append(cover);
(async () => { await ready(); cover.remove(); })();"""


def screenshot(page: str, hash_: str, out: str, size=(800, 600), tries: int = 3) -> np.ndarray:
    """The window (h, w, 3) of ``page#hash_`` once the page has drawn."""
    driven = page.replace(".html", "-covered.html")
    with open(page, encoding="utf-8") as f, open(driven, "w", encoding="utf-8") as g:
        g.write(f.read().replace("</body>", f"<script>\n{WAIT}{COVER}\n</script></body>"))
    for _ in range(tries):
        subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--hide-scrollbars",
                        f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=30000", f"--screenshot={out}",
                        f"file://{driven}#{hash_}"], check=True, timeout=180, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        shot = np.asarray(Image.open(out).convert("RGB"))
        if shot.max() > 0:
            return shot
    raise AssertionError(f"the page had not drawn in {tries} screenshots")


def test_outfits_from_the_address_are_puppet_render_composited(room):
    from puppet.room.model import wear

    seen = browse(room.path, "outfit=jeans,shirt", OUTFITS)
    assert [seen["w0"], seen["w1"], seen["w2"]] == ["jeans,shirt", "jeans,vest,cap", "jeans,shirt"]
    assert seen["tuck"] == "true"
    refs = [wear(room.model, {"jeans", "shirt"}), wear(room.model, {"vest", "cap", "jeans"}), tucked_reference(room.model)]
    for k, ref in enumerate(refs):
        got = png(seen[f"o{k}"])
        assert got.shape == ref.shape and grey_off(got, ref) < 0.02, k
    assert grey_off(refs[0], refs[2]) > 0.02  # tucking in shows the jeans over the shirt's hem
    assert tuple(png(seen["o2"])[45, 32, :3]) == GARMENTS["jeans"][0]
    assert tuple(png(seen["o0"])[45, 32, :3]) == GARMENTS["shirt"][0]
    # what the screen shows: the canvas at the page's top left, 1:1 on a desktop-sized window
    w, h = SIZE
    screen = screenshot(room.path, "outfit=cap,vest", os.path.join(room.folder, "shot.png"))[:h, :w]
    assert grey_off(screen, wear(room.model, {"cap", "vest"})[..., :3]) < 0.02
    assert grey_off(screen, wear(room.model, set())[..., :3]) > 0.05  # the garments show


CLICKS = """(async () => {
  await ready();
  const log = [], canvas = doc.getElementById("room-canvas");
  const item = (name) => doc.querySelector(`.room-item[data-name="${name}"]`);
  const centre = (el) => { const r = el.getBoundingClientRect(); return [r.left + r.width / 2, r.top + r.height / 2]; };
  const pointer = (type, [x, y], target) => target.dispatchEvent(new PointerEvent(type,
      {bubbles: true, clientX: x, clientY: y, pointerId: 7, pointerType: "touch", isPrimary: true, button: 0}));
  const state = () => log.push(doc.body.dataset.outfit + "|" + decodeURIComponent(location.hash));
  async function tap(name) { const n = draws(); pointer("pointerdown", centre(item(name)), item(name));
                             pointer("pointerup", centre(item(name)), item(name)); await after(n); state(); }
  async function drag(name, to, wears = true) {
    const n = draws(), from = centre(item(name));
    pointer("pointerdown", from, item(name));
    for (let k = 1; k <= 5; k++) pointer("pointermove", [from[0] + (to[0] - from[0]) * k / 5, from[1] + (to[1] - from[1]) * k / 5], window);
    pointer("pointerup", to, doc.elementFromPoint(to[0], to[1]) || window);
    if (wears) await after(n); else await wait(200);  // a drop that wears draws (once the pictures are loaded)
    state();
  }
  const onCanvas = (x, y) => { const r = canvas.getBoundingClientRect();  // canvas pixel -> client point
                               return [r.left + (x + 0.5) * r.width / canvas.width, r.top + (y + 0.5) * r.height / canvas.height]; };
  state();
  await tap("shirt");
  await drag("jeans", onCanvas(32, 60));
  await drag("vest", onCanvas(32, 30));       // a second top replaces the first
  {  // dragged over the mannequin a garment shows worn before the drop, and goes when dragged away
    const from = centre(item("shirt")), rgb = () => Array.from(canvas.getContext("2d").getImageData(32, 30, 1, 1).data)
        .slice(0, 3).join(" ");
    pointer("pointerdown", from, item("shirt"));
    pointer("pointermove", [from[0] + 10, from[1]], window); pointer("pointermove", onCanvas(32, 30), window);
    while (doc.body.dataset.shown !== "jeans,shirt") await wait(20);
    const over = rgb();
    pointer("pointermove", from, window); pointer("pointerup", from, item("shirt"));
    while (doc.body.dataset.shown !== "jeans,vest") await wait(20);
    log.push(over + "/" + rgb() + "/" + doc.body.dataset.outfit);
  }
  await drag("cap", centre(doc.getElementById("room-shelf")), false);  // dropped off the mannequin: nothing
  await drag("cap", onCanvas(10, 10));        // anywhere on the mannequin's picture
  let n = draws(); const [x, y] = onCanvas(32, 30);
  canvas.dispatchEvent(new MouseEvent("click", {bubbles: true, clientX: x, clientY: y})); await after(n); state();
  n = draws(); canvas.dispatchEvent(new MouseEvent("click", {bubbles: true, ...Object.fromEntries(
      [["clientX", onCanvas(2, 78)[0]], ["clientY", onCanvas(2, 78)[1]]])})); await wait(100);
  log.push(String(draws() === n));          // a click on the bare mannequin takes nothing off
  await tap("jeans");
  n = draws(); item("jeans").dispatchEvent(new KeyboardEvent("keydown", {key: "Enter", bubbles: true})); await after(n);
  log.push(doc.body.dataset.outfit + "|" + item("jeans").getAttribute("aria-pressed"));
  n = draws(); item("jeans").dispatchEvent(new KeyboardEvent("keydown", {key: " ", bubbles: true})); await after(n);
  let saved = null;
  HTMLAnchorElement.prototype.click = function () { saved = this.download + " " + this.href.slice(0, 5); };
  doc.getElementById("room-download").click();
  while (!saved) await wait(20);
  log.push(saved);
  const r = canvas.getBoundingClientRect();
  log.push([r.width, r.height, innerWidth, innerHeight].map(Math.round).join("x"));
  doc.body.dataset.log = log.join(";");
})();"""


def test_clicks_and_drags_put_garments_on_and_off_on_a_phone_sized_page(room):
    seen = browse(room.path, "", CLICKS, size=(390, 844))
    log = seen["log"].split(";")
    shirt, vest = (" ".join(map(str, GARMENTS[n][0])) for n in ("shirt", "vest"))
    assert log[:8] == ["|", "shirt|#outfit=shirt", "jeans,shirt|#outfit=jeans,shirt", "jeans,vest|#outfit=jeans,vest",
                       f"{shirt}/{vest}/jeans,vest",  # the shirt previewed over the mannequin, then not
                       "jeans,vest|#outfit=jeans,vest", "jeans,vest,cap|#outfit=jeans,vest,cap",
                       "jeans,cap|#outfit=jeans,cap"], log
    assert log[8:12] == ["true", "cap|#outfit=cap", "jeans,cap|true", "cap.png blob:"], log  # keys: on, off
    # the mannequin as large as the phone allows: its width, or 55 % of its height (the shelf below)
    w, h, sw, sh = map(int, log[12].split("x"))
    assert abs(w * SIZE[1] - h * SIZE[0]) <= SIZE[1] and (w == sw or abs(h - 0.55 * sh) <= 1) and w > 300, log[12]


def catalogue(n: int, folder: str):
    """A room of ``n`` garments made in numpy (no scene rendered): small rectangles of
    several colours on the test mannequin, accessories, so any number can be worn."""
    from puppet.room.model import Garment, Room

    mannequin = np.asarray(Image.open(art.mannequin(folder)).convert("RGBA"))
    h, w = mannequin.shape[:2]
    garments = []
    for k in range(n):
        rgba = np.zeros((h, w, 4), np.uint8)
        x, y = 4 + (k * 7) % (w - 16), 4 + (k * 11) % (h - 16)
        rgba[y:y + 10, x:x + 10] = ((k * 37) % 256, (k * 91) % 256, 200, 255)
        depth = np.where(rgba[..., 3] > 0, 0.0, np.nan)
        garments.append(Garment(name=f"g{k:04d}", category="accessory", order=0.0, file="", rgba=rgba, depth=depth))
    return Room(mannequin=mannequin, garments=garments)


@pytest.fixture()
def served(tmp_path):
    """An HTTP server of ``tmp_path`` on 127.0.0.1 (a folder room must be served, as a shop does)."""
    import functools
    import http.server
    import threading

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(tmp_path)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield tmp_path, f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


LAZY = """(async () => {
  const wait = (ms) => new Promise((r) => setTimeout(r, ms));
  while (document.body.dataset.ready !== "1") await wait(20);
  const got = () => performance.getEntriesByType("resource").map((e) => e.name.replace(/^.*\\/pictures\\//, ""));
  await wait(300);
  const before = got();
  // the shelf scrolled to its last garment: its sheet comes (within 10 s of real time)
  document.querySelector('[data-index="299"]').scrollIntoView();
  for (let k = 0; k < 500 && !got().includes("thumbs-005.png"); k++) await wait(20);
  await wait(300);
  return {before, after: got(), outfit: document.body.dataset.outfit};
})()"""


@pytest.mark.parametrize("size", [(800, 600), (1920, 1080)])
def test_the_folder_form_loads_what_it_shows(served, size):
    from puppet.room.page import write_room_folder
    from tests.room.cdp import Browser

    root, url = served
    room = catalogue(300, str(root))
    write_room_folder(room, str(root / "room"), "room/")
    with Browser(CHROMIUM, size=size) as browser:  # real time: a scripted scroll's observers run
        browser.open(f"{url}/room/index.html#outfit=g0000,g0299")
        seen = browser.run(LAZY)
    before, after = seen["before"], seen["after"]
    # (the thumbnails on sheets of 64: a 1920 x 1080 window shows about 165 of them, 3 sheets)
    sheets = [n for n in before if n.startswith("thumbs-")]
    assert 1 <= len(sheets) <= 4 and len(before) < 60, before
    assert not {n for n in before if n.endswith(".png") and "-" not in n} - {"mannequin.png", "0001.png", "0300.png"}
    # first screen: the mannequin, the two worn garments' picture and depth, the thumbnails in view
    assert "mannequin.png" in before and {"0001.png", "0001-depth.png", "0300.png", "0300-depth.png"} <= set(before)
    # the last sheet (thumbs-005.png, g0256..g0299) is not loaded before the shelf is scrolled to it,
    # and is after; scrolling loads sheets only (no garment's picture)
    assert "thumbs-005.png" not in before and "thumbs-005.png" in after, after
    assert all(n.startswith("thumbs-") for n in after[len(before):]), after
    assert seen["outfit"] == "g0000,g0299"
