"""End to end in a real X window (Xvfb, real X events from xdotool): open a bundled scene,
drag a pin, Ctrl+S, and check that ``puppet render --pose <that pose>`` of the saved file
matches the canvas in a screenshot (after undoing the view transform); Ctrl+Z restores."""
from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

import puppet
from tests.conftest import ROOT, SCENES

TOOLS = ("Xvfb", "xdotool", "import")
MISSING = [t for t in TOOLS if shutil.which(t) is None]

pytestmark = [
    pytest.mark.gl, pytest.mark.xvfb, pytest.mark.slow,
    pytest.mark.skipif(bool(MISSING), reason=f"end-to-end X test needs {', '.join(MISSING)} "
                       "(apt-get install xvfb xauth xdotool imagemagick; .ci/run does it as root)"),
]


@pytest.fixture
def display():
    """A private Xvfb server (24-bit: a 16-bit screen hangs window mapping; -noreset: no
    server reset, refusing connections, each time the last client leaves)."""
    r, w = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-noreset"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    number, end = b"", time.monotonic() + 20
    while not number.endswith(b"\n") and time.monotonic() < end:  # "N\n" once it is ready
        if select.select([r], [], [], 0.5)[0]:
            chunk = os.read(r, 32)
            if not chunk:
                break
            number += chunk
    number = number.decode().strip()
    if not number or proc.poll() is not None:
        proc.kill()
        os.close(r)
        pytest.skip("Xvfb did not start")
    name = f":{number}"
    yield name
    proc.terminate()
    proc.wait(10)
    os.close(r)  # kept open: Xvfb dies of SIGPIPE if it writes to a closed pipe


def x(display, *args, check=True) -> str:
    env = dict(os.environ, DISPLAY=display)
    out = subprocess.run(list(args), env=env, capture_output=True, text=True, timeout=30)
    if check and out.returncode:
        raise RuntimeError(f"{args}: {out.stderr}")
    return out.stdout


def wait_ready(app, timeout: float = 90.0) -> dict:
    """The JSON an app process prints after ``ready`` once its first frame is drawn
    (RuntimeError with its stderr if it exits first)."""
    line, end = "", time.monotonic() + timeout
    while time.monotonic() < end and "ready" not in line:
        if select.select([app.stdout], [], [], 1.0)[0]:
            line = app.stdout.readline()
        if app.poll() is not None:
            raise RuntimeError(f"the app exited: {app.stderr.read()}")
    if "ready" not in line:
        raise TimeoutError("the app printed no ready line")
    return json.loads(line.split("ready", 1)[1])


def wait_title(display, pattern: str, timeout: float = 30.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if x(display, "xdotool", "search", "--name", pattern, check=False).strip():
            return
        time.sleep(0.1)
    raise TimeoutError(f"no window titled {pattern!r}")


def screenshot(display, path) -> np.ndarray:
    x(display, "import", "-window", "root", str(path))
    return np.asarray(Image.open(path).convert("RGB"), np.float64)


def canvas_from_screen(shot: np.ndarray, info: dict, size) -> np.ndarray:
    """Undo the view transform: sample the screenshot at every canvas pixel centre
    (bilinear), giving a (H, W, 3) image in canvas pixels."""
    W, H = size
    s = info["scale"]
    ox, oy = info["canvas"][0], info["canvas"][1]
    gx, gy = np.meshgrid((np.arange(W) + 0.5) * s + ox - 0.5, (np.arange(H) + 0.5) * s + oy - 0.5)
    x0, y0 = np.floor(gx).astype(int), np.floor(gy).astype(int)
    fx, fy = (gx - x0)[..., None], (gy - y0)[..., None]
    a, b = shot[y0, x0], shot[y0, x0 + 1]
    c, d = shot[y0 + 1, x0], shot[y0 + 1, x0 + 1]
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy


def render(path, pose, out, env):
    args = [sys.executable, "-m", "puppet", "render", str(path), "-o", str(out), "--pose", pose]
    subprocess.run(args, check=True, env=env, timeout=120, cwd=ROOT)
    return np.asarray(Image.open(out).convert("RGB"), np.float64)


def test_drag_save_render_matches_the_window(display, tmp_path):
    scene = puppet.load_scene(os.path.join(SCENES, "trex-layers.json"))
    path = tmp_path / "trex.json"
    scene.save(str(path))
    poses = set(scene.data.poses)
    scene.close()
    env = dict(os.environ, DISPLAY=display, PYTHONPATH=ROOT)
    env.pop("PYGLET_HEADLESS", None)
    app = subprocess.Popen([sys.executable, "-m", "puppet", "app", str(path)], env=env, cwd=str(tmp_path),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        info = wait_ready(app)
        wait_title(display, r"^puppet .*trex\.json$")
        s, (ox, oy) = info["scale"], info["canvas"][:2]
        hand = np.array([124.0, 251.0])  # the T-rex's front hand pin
        start = np.round(hand * s + (ox, oy)).astype(int)
        steps = [start + np.round(np.array([k * 6, -k * 9])).astype(int) for k in range(1, 9)]
        cmd = ["xdotool", "mousemove", *map(str, start), "sleep", "0.2", "mousedown", "1"]
        for p in steps:
            cmd += ["sleep", "0.05", "mousemove", *map(str, p)]
        cmd += ["sleep", "0.3", "mouseup", "1"]
        x(display, *cmd)
        wait_title(display, r"^puppet .*trex\.json \*$")
        x(display, "xdotool", "key", "ctrl+s")
        wait_title(display, r"^puppet .*trex\.json$")
        # pins hidden, pointer over the side panel: the canvas alone in the screenshot
        x(display, "xdotool", "key", "h", "mousemove", "1200", "760")
        time.sleep(0.5)
        shot = screenshot(display, tmp_path / "shot.png")
        saved = json.loads(path.read_text())
        new = [p for p in saved["poses"] if p not in poses]
        assert len(new) == 1
        target = saved["poses"][new[0]]["hand_front"]
        target = target["to"] if isinstance(target, dict) else target
        np.testing.assert_allclose(target, hand + (steps[-1] - start) / s, atol=1.0 / s + 1e-6)
        cli = render(path, new[0], tmp_path / "cli.png", env)
        shown = canvas_from_screen(shot, info, cli.shape[1::-1])
        diff = np.abs(shown - cli)
        print(f"screen vs render: mean {diff.mean():.2f}, p99 {np.percentile(diff, 99):.1f} grey levels")
        assert diff.mean() < 1.0 and np.percentile(diff, 99) < 6  # within a few grey levels
        off = (diff.max(axis=2) > 24).sum()  # pixels really different (resampled edges only)
        assert off < 0.002 * diff.shape[0] * diff.shape[1]
        saved_scene = puppet.load_scene(str(path))
        rest = saved_scene.render(pose="rest")[..., :3].astype(np.float64)
        saved_scene.close()
        moved = (np.abs(shown - rest).max(axis=2) > 24).sum()
        assert moved > 10 * max(off, 100)  # the comparison tells the poses apart
        # Ctrl+Z: the drag (and the pose it made) is undone; the canvas shows rest again
        x(display, "xdotool", "mousemove", "400", "400", "key", "ctrl+z", "mousemove", "1200", "760")
        wait_title(display, r"^puppet .*trex\.json \*$")
        time.sleep(0.5)
        undone = canvas_from_screen(screenshot(display, tmp_path / "undone.png"), info, cli.shape[1::-1])
        assert np.abs(undone - rest).mean() < 1.0 and (np.abs(undone - rest).max(axis=2) > 24).sum() < moved / 10
        assert app.poll() is None  # still running
    finally:
        app.terminate()
        try:
            app.wait(10)
        except subprocess.TimeoutExpired:
            app.kill()
