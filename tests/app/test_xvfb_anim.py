"""End to end in a real X window (Xvfb, xdotool): scrub the timeline, record a pin's drag
in record mode, Ctrl+S; the saved keys hold the recorded motion, and the canvas shown at
the playhead matches ``puppet render --time`` of the saved file."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from tests.app.test_xvfb import (MISSING, canvas_from_screen, display, screenshot, wait_ready,  # noqa: F401
                                 wait_title, x)
from tests.app.harness import pin_keys
from tests.conftest import ROOT, bar_image, bar_scene

pytestmark = [
    pytest.mark.gl, pytest.mark.xvfb, pytest.mark.slow,
    pytest.mark.skipif(bool(MISSING), reason=f"end-to-end X test needs {', '.join(MISSING)}"),
]


def wait_info(path, test, timeout=120.0) -> dict:
    """The app's widget rects file once ``test(info)`` holds."""
    end = time.monotonic() + timeout
    info = {}
    while time.monotonic() < end:
        try:
            with open(path) as f:
                info = json.load(f)
            if test(info):
                return info
        except (OSError, ValueError):
            pass
        time.sleep(0.2)
    raise TimeoutError(f"the app did not get there: {info.get('status')!r}")


def centre(info, name):
    x0, y0, x1, y1 = info["rects"][name]
    return str(int((x0 + x1) / 2)), str(int((y0 + y1) / 2))


def test_record_a_drag_save_and_render(display, tmp_path):
    from tests.conftest import write_rgba

    write_rgba(tmp_path / "bar.png", bar_image())
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(bar_scene()))
    rects = tmp_path / "rects.json"
    env = dict(os.environ, DISPLAY=display, PYTHONPATH=ROOT, PUPPET_APP_RECTS=str(rects))
    env.pop("PYGLET_HEADLESS", None)
    app = subprocess.Popen([sys.executable, "-m", "puppet", "app", str(path), "--size", "1100x700"], env=env,
                           cwd=str(tmp_path), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_ready(app)
        wait_title(display, r"^puppet .*scene\.json$")
        info = wait_info(rects, lambda i: "timeline" in i["rects"] and not i["busy"])
        # scrub to 0.5 s on the ruler (the ruler shows 2 s), then Record
        x0, y0, x1, _ = info["rects"]["timeline"]
        tx = (x0 + 120) + 0.5 * ((x1 - 10) - (x0 + 120)) / 2.0
        x(display, "xdotool", "mousemove", str(int(round(tx))), str(int(y0 + 6)), "click", "1")
        x(display, "xdotool", "mousemove", *centre(info, "Record"), "click", "1")
        # the view from a dump written after the click: one read at start could predate the
        # fit (the dump is written 5 times a second), and the drag then missed the pin
        info = wait_info(rects, lambda i: "Record on" in i["status"])
        # drag the right pin (where the frame at 0.5 s shows it) up and left for about 1.5 s
        import puppet

        at = np.array(puppet.load_scene(str(path)).pose_at(0.5)["right"], float)
        s, (ox, oy) = info["scale"], info["origin"]  # the view now (the timeline took the bottom)
        start = np.round(at * s + (ox, oy)).astype(int)
        cmd = ["xdotool", "mousemove", *map(str, start), "sleep", "0.3", "mousedown", "1"]
        for k in range(1, 31):
            p = start + np.round([-2.0 * k, -40 * np.sin(k / 30 * np.pi)]).astype(int)
            cmd += ["sleep", "0.05", "mousemove", *map(str, p)]
        cmd += ["sleep", "0.3", "mouseup", "1"]
        x(display, *cmd)
        info = wait_info(rects, lambda i: i["status"].startswith("recorded") and not i["busy"])
        x(display, "xdotool", "key", "ctrl+s")
        wait_title(display, r"^puppet .*scene\.json$")
        saved = json.loads(path.read_text())
        keyed = pin_keys(saved["animation"]["keys"], "right")
        times = sorted(keyed)
        assert len(times) >= 2, saved["animation"]
        assert abs(times[0] - 0.5) < 0.051  # from the playhead (a frame at 10 fps)
        assert times[-1] > 1.0
        last = np.array(keyed[times[-1]])
        np.testing.assert_allclose(last, at + np.array([-60.0, 0.0]) / s, atol=4.0 / s + 0.05)
        # the canvas shows the frame at the playhead (back at 0.5 s): as puppet render --time 0.5
        x(display, "xdotool", "key", "h", "mousemove", "1050", "650")
        time.sleep(1.0)
        shot = screenshot(display, tmp_path / "shot.png")
        out = tmp_path / "cli.png"
        subprocess.run([sys.executable, "-m", "puppet", "render", str(path), "-o", str(out), "--time", "0.5"],
                       check=True, env=env, timeout=120, cwd=ROOT)
        cli = np.asarray(Image.open(out).convert("RGB"), np.float64)
        shown = canvas_from_screen(shot, {"scale": s, "canvas": [ox, oy]}, cli.shape[1::-1])
        diff = np.abs(shown - cli)
        assert diff.mean() < 2.0 and np.percentile(diff, 99) < 40, (diff.mean(), np.percentile(diff, 99))
        x(display, "xdotool", "key", "ctrl+q")
        app.wait(30)
    finally:
        if app.poll() is None:
            app.kill()
            app.wait(10)
