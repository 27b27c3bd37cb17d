"""The task script in a real X window (Xvfb, xdotool): ``puppet app runner.png`` on the
flattened noto-emoji runner, threshold, a lasso clone of the front arm, the body's
refill, a refused link segment and one whose part outside the overlap is dropped
(shot while it drags), pins, Deform, a drag of the fist, Ctrl+S; a
screenshot of each step is kept (``PUPPET_ARTEFACTS`` folder, else the test's temporary
folder) and the saved scene renders through the CLI like the canvas.

The app reports where its buttons and canvas are through ``PUPPET_APP_RECTS`` (a JSON
file it rewrites a few times a second)."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

import puppet
from tests.app.test_script import ACROSS, ARM, FIST, OUTSIDE, flat_runner
from tests.app.test_xvfb import MISSING, display, render, wait_ready, x  # noqa: F401 - display is a fixture
from tests.conftest import ROOT

pytestmark = [
    pytest.mark.gl, pytest.mark.xvfb, pytest.mark.slow,
    pytest.mark.skipif(bool(MISSING), reason=f"end-to-end X test needs {', '.join(MISSING)}"),
]
SIZE = (1280, 800)
#: the screenshots docs/app.md shows (step name -> file under docs/app/)
DOCS = {"layers": "script-layers", "link": "script-link", "pins": "script-pins", "deform": "script-deform"}


class XApp:
    """``puppet app`` in Xvfb, driven by xdotool."""

    def __init__(self, display, picture, folder):
        self.display, self.folder = display, folder
        self.rects_file = os.path.join(folder, "rects.json")
        env = dict(os.environ, DISPLAY=display, PYTHONPATH=ROOT, PUPPET_APP_RECTS=self.rects_file)
        env.pop("PYGLET_HEADLESS", None)
        self.proc = subprocess.Popen([sys.executable, "-m", "puppet", "app", picture, "--size", "%dx%d" % SIZE],
                                     env=env, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.env = env
        wait_ready(self.proc)
        self.settle()

    def info(self) -> dict:
        for _ in range(50):
            try:
                with open(self.rects_file) as f:
                    return json.load(f)
            except (OSError, ValueError):
                time.sleep(0.1)
        raise RuntimeError("the app wrote no widget positions")

    def settle(self, timeout: float = 60.0) -> dict:
        """Wait until the scene thread is idle and the window has shown it (twice in a row)."""
        time.sleep(0.5)
        end, calm = time.monotonic() + timeout, 0
        while time.monotonic() < end:
            i = self.info()
            calm = calm + 1 if not i["busy"] else 0
            if calm >= 3:
                return i
            time.sleep(0.2)
        raise TimeoutError("the app stayed busy")

    def screen(self, xy):
        i = self.info()
        return [int(round(xy[0] * i["scale"] + i["origin"][0])), int(round(xy[1] * i["scale"] + i["origin"][1]))]

    def click_widget(self, label, fx=0.5):
        x0, y0, x1, y1 = self.info()["rects"][label]
        x(self.display, "xdotool", "mousemove", str(int(x0 + fx * (x1 - x0))), str(int((y0 + y1) / 2)),
          "sleep", "0.1", "click", "1")
        return self.settle()

    def click_canvas(self, xy):
        x(self.display, "xdotool", "mousemove", *map(str, self.screen(xy)), "sleep", "0.1", "click", "1")
        return self.settle()

    def press_and_move(self, points, steps=4) -> list[str]:
        """xdotool arguments: press at the first point, move through the others."""
        pts = [self.screen(p) for p in points]
        cmd = ["xdotool", "mousemove", *map(str, pts[0]), "sleep", "0.15", "mousedown", "1"]
        for a, b in zip(pts, pts[1:]):
            for t in np.linspace(0, 1, steps + 1)[1:]:
                q = np.round(np.array(a) + t * (np.array(b) - a)).astype(int)
                cmd += ["sleep", "0.03", "mousemove", *map(str, q)]
        return cmd

    def drag(self, points, steps=4):
        x(self.display, *self.press_and_move(points, steps), "sleep", "0.2", "mouseup", "1")
        return self.settle()

    def hold(self, points, name, steps=4) -> tuple[str, dict]:
        """Press at the first point, move through the others and take a screenshot while
        the button is still down (the live preview), then release; the shot's path and
        what the app reported while the button was down."""
        x(self.display, *self.press_and_move(points, steps))
        time.sleep(0.5)
        path = os.path.join(self.folder, f"{name}.png")
        x(self.display, "import", "-window", "root", path)
        Image.open(path).convert("RGB").crop((0, 0) + SIZE).save(path)
        held = self.info()
        x(self.display, "xdotool", "mouseup", "1")
        self.settle()
        return path, held

    def key(self, *keys):
        x(self.display, "xdotool", "mousemove", "600", "400", "key", *keys)
        return self.settle()

    def shot(self, name) -> str:
        path = os.path.join(self.folder, f"{name}.png")
        x(self.display, "xdotool", "mousemove", "640", "795")  # no tooltip, no hover
        time.sleep(0.4)
        x(self.display, "import", "-window", "root", path)
        Image.open(path).convert("RGB").crop((0, 0) + SIZE).save(path)
        return path

    def close(self):
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def test_task_script_under_x(display, tmp_path):
    out = os.environ.get("PUPPET_ARTEFACTS") or str(tmp_path / "shots")
    os.makedirs(out, exist_ok=True)
    picture = flat_runner(tmp_path)
    t0 = time.monotonic()
    a = XApp(display, picture, str(tmp_path))
    shots = {}
    try:
        assert a.info()["step"] == "image"
        i = a.click_widget("frame:threshold", 0.9)
        shots["image"] = a.shot("1-image")
        a.click_widget("step:layers")
        a.click_widget("+")
        a.drag(ARM + [ARM[0]], steps=3)
        a.click_widget("layer:layer1")
        a.click_widget("inpaint:telea")
        a.shot("2-layers-refill")
        a.click_widget("layer:layer2")  # the arm tinted
        shots["layers"] = a.shot("2-layers")
        a.click_widget("step:link")
        a.drag(OUTSIDE)  # refused: nothing of it where the layers overlap
        assert "no part of the segment" in a.info()["status"]
        shots["link"], held = a.hold(ACROSS, "3-link")  # the kept part solid, the dropped part dashed
        assert held["status"].startswith("link keeps"), held["status"]  # live, while the button is down
        assert a.info()["status"].startswith("link kept"), a.info()["status"]
        shots["link-kept"] = a.shot("3-link-kept")
        a.click_widget("step:pins")
        for p in (FIST, (135.0, 100.0), (78.0, 226.0), (200.0, 168.0)):
            a.click_canvas(p)
        a.click_widget("layer:layer2")
        a.click_widget("check:exterior")  # automatic exterior points on the arm
        assert "exterior" in a.info()["status"] or "change layer" in a.info()["status"]
        shots["pins"] = a.shot("4-pins")
        a.click_widget("step:deform")
        assert a.info()["mode"] == "pose"
        a.drag([FIST, (FIST[0] + 2, FIST[1] - 2), (FIST[0] + 10, FIST[1] - 30)], steps=6)
        shots["deform"] = a.shot("5-deform")
        a.key("ctrl+s")
        took = time.monotonic() - t0
        path = tmp_path / "runner.json"
        assert path.is_file(), a.info()["status"]
        saved = puppet.load_scene(str(path))
        assert [L.name for L in saved.data.layers] == ["layer1", "layer2"]
        assert len(saved.data.links) == 1 and len(saved.data.links[0].segments) == 1
        assert [p.layer for p in saved.data.pins] == ["layer2", "layer1", "layer1", "layer1"]
        pose = saved.active_pose if saved.active_pose != "rest" else next(iter(saved.data.poses))
        assert saved.data.poses[pose]["pin1"].to[1] < FIST[1] - 20
        cli = render(path, pose, tmp_path / "cli.png", a.env)
        np.testing.assert_allclose(cli, saved.render(pose=pose)[..., :3], atol=0)
        saved.close()
        print(f"task script under X: {took:.1f} s; screenshots in {out}")
    finally:
        a.close()
    for step, src in shots.items():
        shutil.copy(src, os.path.join(out, os.path.basename(src)))
        if step in DOCS and os.environ.get("PUPPET_UPDATE_DOCS"):
            shutil.copy(src, os.path.join(ROOT, "docs", "app", DOCS[step] + ".png"))
