"""``puppet app ART.psd`` in a real X window: the app opens the scene made from the art,
a pin dragged and saved makes a pose; the arm recoloured in the PSD and the app opened on
it again keeps that pose and its pins (the rig kept through the re-import) and shows the
new colours."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

from tests import artfiles
from tests.app.test_xvfb import display, pytestmark, screenshot, wait_ready, wait_title, x  # noqa: F401
from tests.conftest import ROOT


def open_app(art, env, cwd, *more):
    """``puppet app ART MORE...`` (no file when ``art`` is None), once its ready line came."""
    files = [] if art is None else [str(art)]
    app = subprocess.Popen([sys.executable, "-m", "puppet", "app", *files, *more], env=env, cwd=str(cwd),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return app, wait_ready(app)


def close(app):
    app.terminate()
    try:
        app.wait(10)
    except subprocess.TimeoutExpired:
        app.kill()


def test_app_on_a_psd_pose_then_reload_changed_art(display, tmp_path):  # noqa: F811
    art = tmp_path / "gbot.psd"
    artfiles.write_psd(str(art))
    env = dict(os.environ, DISPLAY=display, PYTHONPATH=ROOT)
    env.pop("PYGLET_HEADLESS", None)
    app, info = open_app(art, env, tmp_path)
    try:
        assert info["file"] == str(tmp_path / "gbot.json")
        wait_title(display, r"^puppet .*gbot\.json$")
        doc = json.loads((tmp_path / "gbot.json").read_text())
        hand = max((p for p in doc["pins"] if p["layer"] == "arm_front"), key=lambda p: p["at"][0])
        s, (ox, oy) = info["scale"], info["canvas"][:2]
        start = np.round(np.array(hand["at"]) * s + (ox, oy)).astype(int)
        cmd = ["xdotool", "mousemove", *map(str, start), "sleep", "0.2", "mousedown", "1"]
        for k in range(1, 11):
            cmd += ["sleep", "0.05", "mousemove", *map(str, start + np.array([-3 * k, -10 * k]))]
        x(display, *cmd, "sleep", "0.3", "mouseup", "1")
        wait_title(display, r"^puppet .*gbot\.json \*$")
        x(display, "xdotool", "key", "ctrl+s")
        wait_title(display, r"^puppet .*gbot\.json$")
    finally:
        close(app)
    posed = json.loads((tmp_path / "gbot.json").read_text())
    assert len(posed["poses"]) == 1
    artfiles.write_psd(str(art), recolour="arm_front")
    app, info = open_app(art, env, tmp_path)
    try:
        wait_title(display, r"^puppet .*gbot\.json$")
        after = json.loads((tmp_path / "gbot.json").read_text())
        assert after["poses"] == posed["poses"] and after["pins"] == posed["pins"]
        x(display, "xdotool", "key", "h", "mousemove", "1200", "760")  # pins hidden, pointer away
        time.sleep(0.8)
        shot = screenshot(display, tmp_path / "reloaded.png")
        s, (ox, oy) = info["scale"], info["canvas"][:2]
        # the app opens at rest: the hand in the inverted skin colour (255 - (253, 224, 174))
        cx, cy = np.round(np.array(hand["at"]) * s + (ox, oy)).astype(int)
        patch = shot[cy - 12:cy + 12, cx - 12:cx + 12].reshape(-1, 3)
        dark = np.abs(patch - np.array([2, 31, 81])).max(axis=1) < 30
        assert dark.mean() > 0.2, patch.mean(axis=0)
    finally:
        close(app)
