"""How long the gopher-like build of issue 23 takes a person in ``puppet app``: a real
window under Xvfb (1280x800), driven by xdotool at a human pace, through the UI only.

    .venv/bin/python benchmarks/user_gopher.py [--out DIR] [--pace 1.0]

The picture is a flat PNG of a body with an arm holding a drink
(``tests.app.test_gopher.gopher_picture``). The walk: the Layers step, a lasso round the
arm and the drink (Layer via Cut refills the body), the Link step, the Deform panel
opened and scrolled to, its hinge tool, a click on the shoulder, the Pins step, two pins
on the body and one on the hand, the Deform step (meshes built), the hand dragged along
an arc so the arm swings up 60 degrees about the hinge, Ctrl+S.

Human pacing (``--pace`` scales it): 0.6-1 s between clicks, 1-2 s to find a control the
first time it is used, strokes at ~450 screen px/s (a lasso of ~600 px takes ~1.4 s), and
after each action the time until the app shows its result (busy flag of the
``PUPPET_APP_RECTS`` dump). The app's start-up (until its first frame) is printed apart.
A screenshot after each step goes to ``--out`` (not counted in the times); at the end the
saved scene is rendered with ``puppet render --pose`` and compared with the last screenshot
(pins hidden), and the table of steps, seconds and cumulative seconds is printed with the
total and the count of clicks, strokes, scrolls and keys; "app waits" is the part of a
step spent waiting for the app to show the result (with ~0.3 s of polling per action).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import select
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from benchmarks.bench_app import Xvfb  # noqa: E402
from tests.app.test_gopher import AROUND_ARM, BODY_PINS, HAND, SHOULDER, gopher_picture  # noqa: E402 - the same walk

SIZE = (1280, 800)
#: screen px per second of a hand-drawn stroke
STROKE_SPEED = 450.0
SWING = 60.0  # degrees the hand is dragged round the shoulder (up)


class User:
    """``puppet app PICTURE`` in the X server ``x``, used by a person at ``pace``."""

    def __init__(self, x: Xvfb, picture: str, folder: str, out: str, pace: float):
        self.x, self.out, self.pace, self.folder = x, out, pace, folder
        self.rects = os.path.join(folder, "rects.json")
        self.counts = {"clicks": 0, "strokes": 0, "scrolls": 0, "keys": 0}
        self.steps: list[tuple[str, float, float]] = []  # (name, seconds, of which waiting for the app)
        self.waited = 0.0
        env = dict(os.environ, DISPLAY=x.name, PYTHONPATH=ROOT, PUPPET_APP_RECTS=self.rects)
        env.pop("PYGLET_HEADLESS", None)
        t0 = time.monotonic()
        self.proc = subprocess.Popen([sys.executable, "-m", "puppet", "app", picture, "--size", "%dx%d" % SIZE],
                                     env=env, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line, end = "", time.monotonic() + 300
        while "ready" not in line:
            if self.proc.poll() is not None or time.monotonic() > end:
                raise RuntimeError(f"the app did not start: {self.proc.stderr.read()[-2000:]}")
            if select.select([self.proc.stdout], [], [], 0.5)[0]:
                line = self.proc.stdout.readline()
        self.wait()
        self.startup = time.monotonic() - t0
        self.t, self.waited = time.monotonic(), 0.0

    # -- what the app reports --------------------------------------------------------
    def info(self) -> dict:
        for _ in range(100):
            try:
                with open(self.rects) as f:
                    return json.load(f)
            except (OSError, ValueError):
                time.sleep(0.05)
        raise RuntimeError("the app wrote no widget positions")

    def wait(self, timeout: float = 120.0) -> dict:
        """Until the app shows the result: its scene thread idle in two dumps in a row (the
        time counts as waiting for the app; it includes ~0.3 s of polling)."""
        t0 = time.monotonic()
        time.sleep(0.1)
        end, calm = t0 + timeout, 0
        while time.monotonic() < end:
            i = self.info()
            calm = calm + 1 if not i["busy"] else 0
            if calm >= 2:
                self.waited += time.monotonic() - t0
                return i
            time.sleep(0.1)
        raise TimeoutError("the app stayed busy")

    def screen(self, xy) -> list[int]:
        i = self.info()
        return [int(round(xy[0] * i["scale"] + i["origin"][0])), int(round(xy[1] * i["scale"] + i["origin"][1]))]

    # -- a person's hands ------------------------------------------------------------
    def look(self, seconds: float) -> None:
        time.sleep(seconds * self.pace)

    def click_widget(self, label: str, find: float = 0.8) -> None:
        """Find ``label`` (``find`` seconds: ~1.5 the first time), move there, click."""
        self.look(find)
        x0, y0, x1, y1 = self.info()["rects"][label]
        self.x.run("xdotool", "mousemove", str(int((x0 + x1) / 2)), str(int((y0 + y1) / 2)), "sleep",
                   str(0.25 * self.pace), "click", "1")
        self.counts["clicks"] += 1
        self.wait()

    def click_canvas(self, xy, aim: float = 0.8) -> None:
        self.look(aim)
        self.x.run("xdotool", "mousemove", *map(str, self.screen(xy)), "sleep", str(0.2 * self.pace), "click", "1")
        self.counts["clicks"] += 1
        self.wait()

    def stroke(self, points, aim: float = 0.8) -> None:
        """Press at the first canvas point, move through the others at :data:`STROKE_SPEED`
        (one xdotool process, ~60 moves a second), release."""
        self.look(aim)
        pts = np.array([self.screen(p) for p in points], float)
        cmd = ["xdotool", "mousemove", *map(str, pts[0].astype(int)), "sleep", "0.15", "mousedown", "1"]
        for a, b in zip(pts, pts[1:]):
            n = max(int(np.hypot(*(b - a)) / STROKE_SPEED * 60 * self.pace), 1)
            for t in np.linspace(0, 1, n + 1)[1:]:
                cmd += ["sleep", "0.0167", "mousemove", *map(str, np.round(a + t * (b - a)).astype(int))]
        self.x.run(*cmd, "sleep", "0.15", "mouseup", "1")
        self.counts["strokes"] += 1
        self.wait()

    def scroll(self, at, notches: int, find: float = 0.8) -> None:
        self.look(find)
        self.x.run("xdotool", "mousemove", *map(str, at), "click", "--repeat", str(abs(notches)), "--delay", "80",
                   "5" if notches > 0 else "4")
        self.counts["scrolls"] += 1
        self.wait()

    def key(self, *keys, find: float = 0.6) -> None:
        self.look(find)
        self.x.run("xdotool", "mousemove", "470", "300", "key", *keys)
        self.counts["keys"] += len(keys)
        self.wait()

    # -- the record --------------------------------------------------------------------
    def step(self, name: str) -> None:
        """End step ``name``: its time, then a screenshot (not counted)."""
        now = time.monotonic()
        self.steps.append((name, now - self.t, self.waited))
        self.waited = 0.0
        self.shot(f"{len(self.steps):02d}-{name}")
        self.t = time.monotonic()

    def shot(self, name: str) -> str:
        path = os.path.join(self.out, f"{name}.png")
        self.x.run("import", "-window", "root", "-crop", "%dx%d+0+0" % SIZE, path)
        return path

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)


def arc(centre, start, degrees: float, n: int = 12) -> list[tuple[float, float]]:
    """Canvas points from ``start`` round ``centre`` by ``degrees`` (positive: up on screen)."""
    r = math.hypot(start[0] - centre[0], start[1] - centre[1])
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    return [(centre[0] + r * math.cos(a0 - math.radians(degrees) * k / n),
             centre[1] + r * math.sin(a0 - math.radians(degrees) * k / n)) for k in range(n + 1)]


def build(u: User) -> None:
    """The walk of the module doc, step by step."""
    u.click_widget("step:layers", find=1.5)
    u.step("layers step")
    u.stroke(AROUND_ARM, aim=1.5)  # Lasso and Layer via Cut are the step's defaults
    u.step("lasso cut")
    u.click_widget("step:link", find=1.5)
    u.step("link step")
    u.click_widget("link-step:hinge", find=1.5)  # under the step's pencil (also in the Deform panel)
    u.step("hinge tool")
    u.click_canvas(SHOULDER, aim=1.0)
    u.step("hinge click")
    u.click_widget("step:pins", find=1.5)
    for p in BODY_PINS + [HAND]:
        u.click_canvas(p, aim=0.8)
    u.step("pins")
    u.click_widget("step:deform", find=1.5)
    u.step("deform step")
    u.stroke(arc(SHOULDER, HAND, SWING), aim=1.0)
    u.click_widget("mesh", find=1.0)  # the wireframe off, to see the art
    u.step("pose drag")
    u.key("ctrl+s", find=1.0)
    u.step("save")


def check_render(u: User, folder: str) -> str:
    """The saved scene rendered by ``puppet render --pose`` against the window's canvas
    (pins and links hidden): mean and 99th percentile grey-level difference over opaque pixels."""
    from PIL import Image

    from tests.app.test_xvfb import canvas_from_screen

    u.x.run("xdotool", "mousemove", "470", "300", "key", "h", "l", "mousemove", "1200", "790")  # pins, links off
    time.sleep(0.6)
    final = u.shot("final-pins-hidden")
    path = os.path.join(folder, "gopher.json")
    with open(path) as f:
        pose = next(iter(json.load(f)["poses"]))
    out = os.path.join(u.out, "render.png")
    subprocess.run([sys.executable, "-m", "puppet", "render", path, "-o", out, "--pose", pose], check=True,
                   cwd=ROOT, timeout=300)
    rgba = np.asarray(Image.open(out), float)
    info = u.info()
    shown = canvas_from_screen(np.asarray(Image.open(final).convert("RGB"), float),
                               dict(info, canvas=info["origin"]), rgba.shape[1::-1])
    d = np.abs(shown - rgba[..., :3])[rgba[..., 3] == 255]
    return (f"puppet render --pose {pose} vs the window: mean {d.mean():.2f}, p99 {np.percentile(d, 99):.1f} "
            f"grey levels over {len(d)} opaque pixels; {(d.max(axis=1) > 24).sum()} differ by > 24")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="folder for the step screenshots (default: a new temporary folder)")
    ap.add_argument("--docs", action="store_true", help="also write four of the screenshots, 960x600, to docs/app/ "
                    "(gopher-*.png, shown by docs/app.md)")
    ap.add_argument("--pace", type=float, default=1.0, help="scale the human pauses and stroke times")
    args = ap.parse_args()
    folder = tempfile.mkdtemp(prefix="user_gopher-")
    out = args.out or os.path.join(folder, "shots")
    os.makedirs(out, exist_ok=True)
    picture = gopher_picture(os.path.join(folder, "gopher.png"))
    load = os.getloadavg()
    x = Xvfb()
    try:
        u = User(x, picture, folder, out, args.pace)
        try:
            build(u)
            verdict = check_render(u, folder)
        except Exception:
            u.shot("error")
            raise
        finally:
            u.close()
    finally:
        x.close()
    print(f"puppet app start-up (not counted): {u.startup:.1f} s; load before {load[0]:.2f}")
    print(f"{'step':<14} {'seconds':>8} {'cumulative':>11} {'app waits':>10}")
    total = 0.0
    for name, s, w in u.steps:
        total += s
        print(f"{name:<14} {s:8.1f} {total:11.1f} {w:10.1f}")
    c = u.counts
    print(f"total {total:.1f} s ({total / 60:.1f} min); {c['clicks']} clicks, {c['strokes']} strokes, "
          f"{c['scrolls']} scrolls, {c['keys']} keys")
    print(verdict)
    print(f"screenshots: {out}")
    if args.docs:
        write_docs(out)


#: step screenshot -> the picture docs/app.md shows
DOCS = {"02-lasso cut": "gopher-cut", "05-hinge click": "gopher-hinge", "06-pins": "gopher-pins",
        "09-save": "gopher-posed"}


def write_docs(out: str) -> None:
    from PIL import Image

    for shot, name in DOCS.items():
        im = Image.open(os.path.join(out, shot + ".png")).convert("RGB")
        im.resize((960, 600), Image.LANCZOS).save(os.path.join(ROOT, "docs", "app", name + ".png"), optimize=True)


if __name__ == "__main__":
    main()
