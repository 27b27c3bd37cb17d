"""What a user sees while dragging pins in ``puppet app``: a real window under Xvfb (GLX)
at 1280x800, real pointer events from ONE xdotool process at 60 Hz, and the window
captured at 60 fps with PyAV's x11grab; a captured frame counts as a canvas update when
the canvas changed outside the pin markers' path (a disc round each dragged pin's route,
so that marker moves do not count as poses), and as a marker update when it changed
inside that path. Drags: a single pin, 3 pins and a key drag on the T-rex, one pin on a
4000x4000 garment photo, a middle pin (``common.middle_pin``) on the 20-part 4000x4000
PSD of issue 31 (``psd4k``, made once into ``bench_scale``'s folder); beside them, the same
drags replayed in a headless window (EGL, no X, events dispatched in-process), the figure
the app's loop alone reaches.

    .venv/bin/python benchmarks/bench_app.py [--steps 120] [--only real|headless] [--scenes trex,garment,psd4k]

CPU/update: the app process's CPU time during the drag (every thread: the window, the
scene thread, llvmpipe's rasterizers) over the canvas updates shown, a figure the load of
the machine changes less than the rates: 2 cores give at most 2000 / it updates a second.
Release is the time from the mouse-up to the last canvas change (the exact pose shown).
How far the last preview stands from the release: in the real window, the optical flow
(Farneback) from the last canvas frame captured before the mouse-up to the settled one,
95th percentile over the art's edges (window px); in the headless window, the vertices of
the last preview shown against the released pose (``common.pose_gap``, canvas px, 95th
percentile / max). The capture shares the machine with the app (decoding, comparing frames).
"""
from __future__ import annotations

import argparse
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from benchmarks.common import middle_pin, pose_gap, psd4k_scene  # noqa: E402

TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
SIZE = (1280, 800)
HZ = 60.0
#: radius (window px) of the disc masked round each dragged pin's route
MARKER_MASK = 16
#: (scene, label, pins, pose to drag in, time of a key drag or None)
#: the pins of benchmarks/bench_drag.py's drags
TREX_DRAGS = [("trex", "single pin", ["hand_front"], "wave", None),
              ("trex", "3 pins", ["tail_tip", "jaw", "hand_front"], "wave", None),
              ("trex", "key at 0.75 s", ["tail_tip", "hand_front"], None, 0.75)]


def pointer_path(start, steps: int, radius: float = 70.0) -> np.ndarray:
    """Window points of a drag: from ``start`` once round a circle of ``radius``."""
    t = np.linspace(0, 2 * np.pi, steps)
    c = np.asarray(start, float) + (radius, 0)
    return np.stack([c[0] - radius * np.cos(t), c[1] - radius * np.sin(t)], axis=1)


def garment_scene(folder: str) -> str:
    """The 4000x4000 garment photo scene of ``bench_drag`` (made once per folder)."""
    path = os.path.join(folder, "shirt4k.json")
    os.makedirs(folder, exist_ok=True)
    if not os.path.exists(path):
        from benchmarks.bench_drag import garment_4k

        garment_4k(folder)
    return path


def garment_pin(path: str) -> str:
    """The garment's pin that bench_drag drags (``end1``), else the right-most one."""
    with open(path) as f:
        pins = json.load(f)["pins"]
    names = [p["name"] for p in pins]
    return "end1" if "end1" in names else max(pins, key=lambda p: p["at"][0])["name"]


# -- the real window -------------------------------------------------------------------------
class Xvfb:
    """A private X server (24-bit; -noreset keeps it up between apps)."""

    def __init__(self):
        r, w = os.pipe()
        self.proc = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1280x1024x24", "-nolisten",
                                      "tcp", "-noreset"], pass_fds=(w,), stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        os.close(w)
        number, end = b"", time.monotonic() + 20
        while not number.endswith(b"\n") and time.monotonic() < end:
            if select.select([r], [], [], 0.5)[0]:
                number += os.read(r, 32) or b"\n"
        self._pipe = r
        self.name = f":{number.decode().strip()}"

    def run(self, *args, check=True) -> str:
        out = subprocess.run(list(args), env=dict(os.environ, DISPLAY=self.name), capture_output=True, text=True,
                             timeout=120)
        if check and out.returncode:
            raise RuntimeError(f"{args[:3]}: {out.stderr}")
        return out.stdout

    def close(self) -> None:
        self.proc.terminate()
        self.proc.wait(10)
        os.close(self._pipe)


class RealApp:
    """``puppet app SCENE`` in a window of the X server ``x``, and where its widgets are."""

    def __init__(self, x: Xvfb, scene: str, folder: str):
        self.x, self.rects = x, os.path.join(folder, "rects.json")
        env = dict(os.environ, DISPLAY=x.name, PYTHONPATH=ROOT, PUPPET_APP_RECTS=self.rects)
        env.pop("PYGLET_HEADLESS", None)
        self.proc = subprocess.Popen([sys.executable, "-m", "puppet", "app", scene, "--size", f"{SIZE[0]}x{SIZE[1]}"],
                                     env=env, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        end, line = time.monotonic() + 600, ""
        while "ready" not in line:
            if self.proc.poll() is not None or time.monotonic() > end:
                raise RuntimeError(f"the app did not start: {self.proc.stderr.read()[-2000:]}")
            if select.select([self.proc.stdout], [], [], 1.0)[0]:
                line = self.proc.stdout.readline()
        wid = x.run("xdotool", "search", "--sync", "--onlyvisible", "--name", "^puppet").split()[0]
        geo = dict(v.split("=") for v in x.run("xdotool", "getwindowgeometry", "--shell", wid).split())
        self.origin = (int(geo["X"]), int(geo["Y"]))
        self.settle()

    def info(self) -> dict:
        with open(self.rects) as f:
            return json.load(f)

    def settle(self, timeout: float = 120.0) -> dict:
        """Wait until the scene thread is idle (the dump is written 5 times a second)."""
        end = time.monotonic() + timeout
        time.sleep(0.5)
        while time.monotonic() < end:
            info = self.info()
            if not info["busy"]:
                time.sleep(0.4)
                if not self.info()["busy"]:
                    return self.info()
            time.sleep(0.2)
        raise TimeoutError("the app stayed busy")

    def click(self, xy, shift: bool = False) -> None:
        x, y = self.screen(xy)
        args = ["xdotool", "mousemove", str(x), str(y)] + (["keydown", "shift"] if shift else []) + ["click", "1"]
        self.x.run(*args + (["keyup", "shift"] if shift else []))

    def screen(self, xy) -> tuple[int, int]:
        return int(round(xy[0] + self.origin[0])), int(round(xy[1] + self.origin[1]))

    def close(self) -> None:
        self.x.run("xdotool", "key", "ctrl+q", check=False)
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)


class Capture:
    """The window captured at 60 fps on a thread; per frame: its time and whether the canvas
    changed outside (pose) and inside (markers) the mask."""

    def __init__(self, x: Xvfb, origin, area, mask: np.ndarray):
        import av

        ax, ay, aw, ah = (int(round(v)) for v in area)
        aw, ah = aw - aw % 2, ah - ah % 2
        # only the canvas area is grabbed: the probe's own copying and decoding take less
        # of the 2 cores the app runs on
        self.container = av.open(f"{x.name}.0+{origin[0] + ax},{origin[1] + ay}", format="x11grab",
                                 options={"framerate": "60", "video_size": f"{aw}x{ah}", "draw_mouse": "0"})
        self.mask = mask[ay:ay + ah, ax:ax + aw]
        self.frames: list[tuple[float, bool, bool]] = []
        #: (time, frame) of the latest canvas changes, and the latest frame
        self.shown: deque = deque(maxlen=60)
        self.last: np.ndarray | None = None
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        prev = None
        for frame in self.container.decode(video=0):
            t = time.time()
            if frame.time is not None and abs(frame.time - t) < 5:
                t = float(frame.time)  # x11grab stamps frames with the wall clock when grabbed
            cur = frame.to_ndarray(format="gray").astype(np.int16)
            if prev is not None:
                diff = np.abs(cur - prev) > 2
                canvas = int(np.count_nonzero(diff & ~self.mask)) > 8
                self.frames.append((t, canvas, int(np.count_nonzero(diff & self.mask)) > 8))
                if canvas:
                    self.shown.append((t, cur))
            prev = self.last = cur
            if self._stop:
                break

    def stop(self) -> None:
        self._stop = True
        self._thread.join(10)
        self.container.close()


def release_jump(preview: np.ndarray, final: np.ndarray, mask: np.ndarray) -> float:
    """How far (px) the canvas moved from the frame ``preview`` to ``final`` (grey frames
    of the canvas area): the 95th percentile of the optical flow (Farneback) over the
    edges of ``final`` outside ``mask``."""
    import cv2  # lazy: only the real window's frames are compared

    a, b = (np.clip(f, 0, 255).astype(np.uint8) for f in (preview, final))
    flow = cv2.calcOpticalFlowFarneback(a, b, None, 0.5, 4, 21, 3, 5, 1.1, 0)
    edges = (np.hypot(cv2.Sobel(b, cv2.CV_32F, 1, 0), cv2.Sobel(b, cv2.CV_32F, 0, 1)) > 40) & ~mask
    return float(np.percentile(np.linalg.norm(flow[edges], axis=1), 95)) if edges.any() else 0.0


def path_mask(paths) -> np.ndarray:
    """(H, W) bool: discs of :data:`MARKER_MASK` round every point of the pins' routes."""
    yy, xx = np.mgrid[0:SIZE[1], 0:SIZE[0]]
    mask = np.zeros((SIZE[1], SIZE[0]), bool)
    for path in paths:
        for x, y in path[:: max(1, len(path) // 240)]:
            x0, x1 = int(max(x - MARKER_MASK, 0)), int(min(x + MARKER_MASK + 1, SIZE[0]))
            y0, y1 = int(max(y - MARKER_MASK, 0)), int(min(y + MARKER_MASK + 1, SIZE[1]))
            sub = (xx[y0:y1, x0:x1] - x) ** 2 + (yy[y0:y1, x0:x1] - y) ** 2 <= MARKER_MASK ** 2
            mask[y0:y1, x0:x1] |= sub
    return mask


def xdotool_drag(app: RealApp, names, steps: int) -> tuple[list, list[str], list[str]]:
    """The pins' routes (window px) and two xdotool commands: one that selects the first
    pins (Shift-clicks; Shift stays down), one that presses the last pin, releases Shift
    and moves at 60 Hz. Only the second is timed: the clicks are not part of the drag (timed
    with it, they took ~0.2 s of a 3-pin drag's 2.3 s and lowered its rates by ~9 %)."""
    info = app.info()
    starts = [info["markers"][n] for n in names]
    path = pointer_path(starts[-1], steps)
    routes = [path + (np.asarray(s) - starts[-1]) for s in starts]
    select = ["xdotool"]
    for k, s in enumerate(starts[:-1]):
        select += ["mousemove", *map(str, app.screen(s))] + (["keydown", "shift"] if k else []) + ["click", "1"]
    if len(names) == 2:
        select += ["keydown", "shift"]
    cmd = ["xdotool", "mousemove", *map(str, app.screen(starts[-1])), "mousedown", "1"]
    if len(names) > 1:
        cmd += ["keyup", "shift"]
    for p in path[1:]:
        cmd += ["mousemove", *map(str, app.screen(p)), "sleep", f"{1 / HZ:.4f}"]
    return routes, select if len(select) > 1 else [], cmd + ["mouseup", "1"]


def cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system, every thread) process ``pid`` has used."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def real_drag(app: RealApp, names, steps: int, after: float = 2.5) -> dict:
    info = app.settle()
    routes, select, cmd = xdotool_drag(app, names, steps)
    if select:
        app.x.run(*select)
        info = app.settle()
    cap = Capture(app.x, app.origin, info["area"], path_mask(routes))
    time.sleep(0.5)
    t0, c0 = time.time(), cpu_seconds(app.proc.pid)
    app.x.run(*cmd)
    t_up, cpu = time.time(), cpu_seconds(app.proc.pid) - c0
    time.sleep(after)
    cap.stop()
    app.settle()
    during = [f for f in cap.frames if t0 + 0.05 <= f[0] <= t_up]
    span = max(t_up - t0 - 0.05, 1e-6)
    changes = [f[0] for f in cap.frames if f[1] and t0 <= f[0] <= t_up + after]
    gaps = np.diff([f[0] for f in during if f[1]]) * 1000
    before = [f for t, f in cap.shown if t <= t_up]
    jump = release_jump(before[-1], cap.last, cap.mask) if before and cap.last is not None else None
    return {"jump_px": jump, "canvas_per_s": sum(f[1] for f in during) / span, "marker_per_s": sum(f[2] for f in during) / span,
            "captured_per_s": len(during) / span, "gap_p95_ms": float(np.percentile(gaps, 95)) if len(gaps) else None,
            "release_ms": max(0.0, (max(changes) - t_up) * 1000) if changes else None, "drag_s": span,
            "cpu_ms_per_update": 1000 * cpu / max(sum(f[1] for f in during), 1)}


def grab(app: RealApp, path: str) -> None:
    """Save the app's window (colour) as the PNG ``path``."""
    import av  # lazy: only screenshots and the capture grab the screen

    with av.open(f"{app.x.name}.0+{app.origin[0]},{app.origin[1]}", format="x11grab",
                 options={"video_size": f"{SIZE[0]}x{SIZE[1]}", "draw_mouse": "1"}) as c:
        next(c.decode(video=0)).to_image().save(path)


def shots(app: RealApp, name: str, folder: str) -> None:
    """Three screenshots of a drag of pin ``name`` into ``folder``: before, while held
    (a preview, once the app is idle) and after the release."""
    start = app.info()["markers"][name]
    to = np.asarray(start, float) + (60, -40)
    grab(app, os.path.join(folder, "1-before.png"))
    app.x.run("xdotool", "mousemove", *map(str, app.screen(start)), "mousedown", "1",
              *[a for p in np.linspace(start, to, 8)[1:] for a in ("mousemove", *map(str, app.screen(p)), "sleep", "0.05")])
    app.settle()
    grab(app, os.path.join(folder, "2-held.png"))
    app.x.run("xdotool", "mouseup", "1")
    app.settle()
    grab(app, os.path.join(folder, "3-released.png"))
    app.x.run("xdotool", "key", "ctrl+z")
    app.settle()


def real_runs(groups, steps: int, shots_to: str | None = None) -> list[dict]:
    """``groups``: [(scene path, its drags as in :data:`TREX_DRAGS`)]; screenshots of the
    first drag of each scene into ``shots_to/SCENE/`` when given."""
    rows = []
    x = Xvfb()
    try:
        folder = tempfile.mkdtemp(prefix="bench-app-")
        for scene, kinds in groups:
            app = RealApp(x, scene, folder)
            try:
                if shots_to:
                    os.makedirs(os.path.join(shots_to, kinds[0][0]), exist_ok=True)
                    shots(app, kinds[0][2][-1], os.path.join(shots_to, kinds[0][0]))
                for name, label, names, pose, t in kinds:
                    info = app.info()
                    if pose is not None:
                        app.click(rect_centre(info["rects"][f"pose:{pose}"]))
                    if t is not None:
                        tl = info["timeline"]
                        app.click((tl["x0"] + t * (tl["x1"] - tl["x0"]) / tl["span"], tl["y0"] + 6))
                    r = real_drag(app, names, steps)
                    rows.append(dict(r, scene=name, kind=label, where="real window"))
            finally:
                app.close()
    finally:
        x.close()
    return rows


def rect_centre(r) -> tuple[float, float]:
    return (r[0] + r[2]) / 2, (r[1] + r[3]) / 2


# -- the headless window (in-process) ----------------------------------------------------------
def headless_drag(scene: str, names, pose, t, steps: int) -> dict:
    """The same drag dispatched into a headless app window run by its own loop."""
    import pyglet

    pyglet.options["headless"] = True
    pyglet.options["debug_gl"] = False
    from tests.app.harness import Driver

    d = Driver(scene, size=SIZE)
    try:
        app = d.app
        if pose is not None:
            app.edit(lambda s: s.set_active_pose(pose))
        if t is not None:
            app.timeline.scrub(t)
        d.settle()
        starts = [d.pin_screen(n) for n in names]
        for k, s in enumerate(starts[:-1]):
            d.click(*s, mods=pyglet.window.key.MOD_SHIFT if k else 0)
        path = pointer_path(starts[-1], steps)
        d.press(*starts[-1], mods=pyglet.window.key.MOD_SHIFT if len(names) > 1 else 0)
        shown, last, preview = [], app.snap.version, None
        t_start = next_event = time.perf_counter()
        c0 = time.process_time()
        k = 0
        while k < len(path):  # the app's own loop (window.run), pointer events at 60 Hz
            now = time.perf_counter()
            if now >= next_event:
                p = path[k]
                d.w.win.dispatch_event("on_mouse_drag", float(p[0]), SIZE[1] - float(p[1]), 0, 0,
                                       pyglet.window.mouse.LEFT, 0)
                d.pos = (float(p[0]), float(p[1]))
                k += 1
                next_event += 1.0 / HZ
            if d.w.step():
                if app.snap.version != last and app.snap.preview:
                    shown.append(time.perf_counter())
                    last, preview = app.snap.version, app.snap.layers
            else:
                time.sleep(0.004)
        elapsed, cpu = time.perf_counter() - t_start, time.process_time() - c0
        d.release()
        t0 = time.perf_counter()
        d.settle()
        release = time.perf_counter() - t0
        gap = pose_gap(preview, app.snap.layers, names[-1]) if preview else None
        return {"canvas_per_s": len(shown) / elapsed, "release_ms": release * 1000,
                "cpu_ms_per_update": 1000 * cpu / max(len(shown), 1),
                "gap_p95": None if gap is None else float(np.percentile(gap, 95)),
                "gap_max": None if gap is None else float(gap.max())}
    finally:
        d.close()


def headless_runs(groups, steps: int) -> list[dict]:
    rows = []
    for scene, drags in groups:
        for name, label, names, pose, t in drags:
            r = headless_drag(scene, names, pose, t, steps)
            rows.append(dict(r, scene=name, kind=label, where="headless"))
    return rows


def scene_drags(names) -> list:
    """[(scene path, its drags as in :data:`TREX_DRAGS`)] of the named scenes, made when missing."""
    groups = [(TREX, TREX_DRAGS)] if "trex" in names else []
    if "garment" in names:
        garment = garment_scene(os.path.join(tempfile.gettempdir(), "puppet-bench-garment"))
        groups.append((garment, [("garment", "single pin", [garment_pin(garment)], None, None)]))
    if "psd4k" in names:
        psd = psd4k_scene(os.path.join(tempfile.gettempdir(), "puppet-bench-scale", "psd4k"))
        groups.append((psd, [("psd4k", "middle pin", [middle_pin(psd)[0]], None, None)]))
    return groups


def fmt(v, spec=".0f") -> str:
    return "-" if v is None else format(v, spec)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=120, help="pointer moves per drag (at 60 Hz)")
    ap.add_argument("--only", choices=("real", "headless"), help="one of the two windows")
    ap.add_argument("--scenes", default="trex,garment", help="any of trex, garment (the 4000x4000 photo), psd4k "
                    "(the 20-part 4000x4000 PSD)")
    ap.add_argument("--solver", choices=("thread", "process"), help="where the app solves drag previews "
                    "(PUPPET_APP_SOLVER; default: the app's)")
    ap.add_argument("--shots", metavar="DIR", help="save screenshots of a drag on each scene (real window) here")
    a = ap.parse_args()
    if a.solver:
        os.environ["PUPPET_APP_SOLVER"] = a.solver  # the app's child and the headless window read it
    groups = scene_drags(a.scenes.split(","))
    from benchmarks.bench_drag import load_floor

    from puppet.app.model.session import SOLVER

    print(f"load average {os.getloadavg()[0]:.1f}, {os.cpu_count()} cores, numpy floor {load_floor():.1f} ms "
          f"(quiet machine: ~3.5 ms); previews solved in a {os.environ.get('PUPPET_APP_SOLVER', SOLVER)}")
    rows = []
    if a.only != "headless":
        missing = [t for t in ("Xvfb", "xdotool") if shutil.which(t) is None]
        if missing:
            sys.exit(f"bench_app: the real window needs {', '.join(missing)}")
        rows += real_runs(groups, a.steps, a.shots)
    if a.only != "real":
        rows += headless_runs(groups, a.steps)
    print(f"{'scene':<10}{'drag':<15}{'window':<13}{'canvas/s':>9}{'marker/s':>9}{'frames/s':>9}"
          f"{'gap p95':>9}{'release':>9}{'CPU/update':>11}   last preview to release (px)")
    for r in rows:
        jump = f"flow p95 {fmt(r.get('jump_px'), '.1f')}" if r["where"] == "real window" else \
            f"vertices p95 {fmt(r.get('gap_p95'), '.1f')} / max {fmt(r.get('gap_max'), '.1f')}"
        print(f"{r['scene']:<10}{r['kind']:<15}{r['where']:<13}{r['canvas_per_s']:>9.1f}"
              f"{fmt(r.get('marker_per_s'), '.1f'):>9}{fmt(r.get('captured_per_s'), '.1f'):>9}"
              f"{fmt(r.get('gap_p95_ms')):>7}ms{fmt(r['release_ms']):>7}ms{fmt(r.get('cpu_ms_per_update')):>9}ms"
              f"   {jump}")
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
