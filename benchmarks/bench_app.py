"""The app's frame time while a pin is dragged: replays a recorded drag (the T-rex's
front hand pulled round a circle, pointer events at 60 Hz) in a headless 1280x800 app
window (EGL, no X) and prints the median and p95 time per frame, and how often the
canvas showed a new pose (updates per second).

    .venv/bin/python benchmarks/bench_app.py [--steps 120] [--size 1280x800]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import pyglet  # noqa: E402

pyglet.options["headless"] = True
pyglet.options["debug_gl"] = False

SCENE = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")


def recorded_drag(start, steps: int, radius: float = 70.0) -> np.ndarray:
    """Window points of a drag: out from ``start`` then once round a circle."""
    t = np.linspace(0, 2 * np.pi, steps)
    c = np.asarray(start, float) + (radius, 0)
    ring = np.stack([c[0] - radius * np.cos(t), c[1] - radius * np.sin(t)], axis=1)
    return ring


def run(steps: int, size: tuple[int, int], pose: str) -> dict:
    from tests.app.harness import Driver

    d = Driver(SCENE, size=size)
    try:
        app = d.app
        if pose != "rest":
            app.edit(lambda s: s.set_active_pose(pose))
        d.settle()
        start = d.pin_screen("hand_front")
        path = recorded_drag(start, steps)
        d.press(*start)
        frame_ms, shown = [], []
        last_version = app.snap.version
        t_start = time.perf_counter()
        period = 1.0 / 60.0
        next_event = time.perf_counter()
        k = 0
        while k < len(path):  # the app's own loop (window.run), pointer events at 60 Hz
            t0 = time.perf_counter()
            if t0 >= next_event:
                p = path[k]
                d.w.win.dispatch_event("on_mouse_drag", float(p[0]), size[1] - float(p[1]), 0, 0,
                                       pyglet.window.mouse.LEFT, 0)
                d.pos = (float(p[0]), float(p[1]))
                k += 1
                next_event += period
            drew = d.w.step()
            t1 = time.perf_counter()
            if drew:
                frame_ms.append((t1 - t0) * 1000)
                if app.snap.version != last_version and app.snap.preview:
                    shown.append(t1)
                    last_version = app.snap.version
            else:
                time.sleep(0.004)
        elapsed = time.perf_counter() - t_start
        d.release()
        t0 = time.perf_counter()
        d.settle()
        exact_ms = (time.perf_counter() - t0) * 1000
        gaps = np.diff(shown) * 1000 if len(shown) > 1 else np.array([np.nan])
        return {"frames": len(frame_ms), "events": len(path), "frame_ms_median": float(np.median(frame_ms)),
                "frame_ms_p95": float(np.percentile(frame_ms, 95)),
                "updates_per_s": len(shown) / elapsed, "update_gap_ms_median": float(np.median(gaps)),
                "update_gap_ms_p95": float(np.percentile(gaps, 95)), "release_to_exact_ms": exact_ms,
                "canvas_px": [int(v) for v in d.app.view.canvas_rect(d.app.snap.canvas)[2:]]}
    finally:
        d.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=120)
    ap.add_argument("--size", default="1280x800")
    ap.add_argument("--pose", default="wave", help="pose to drag in (rest: the drag makes a new pose)")
    a = ap.parse_args()
    size = tuple(int(v) for v in a.size.lower().split("x"))
    r = run(a.steps, size, a.pose)
    print(f"T-rex drag in a {size[0]}x{size[1]} app window (canvas shown at {r['canvas_px'][0]}x{r['canvas_px'][1]} px), "
          f"{r['events']} pointer events at 60 Hz, {r['frames']} frames drawn:")
    print(f"  frame time: median {r['frame_ms_median']:.1f} ms, p95 {r['frame_ms_p95']:.1f} ms")
    print(f"  canvas updates: {r['updates_per_s']:.1f} per second (gap median {r['update_gap_ms_median']:.0f} ms, "
          f"p95 {r['update_gap_ms_p95']:.0f} ms)")
    print(f"  release to exact pose shown: {r['release_to_exact_ms']:.0f} ms")
    print(json.dumps(r))


if __name__ == "__main__":
    main()
