"""Cost of the app's stiffness heat map (Deform panel): window frames in a headless app
window (EGL) with the heat map off and on, on the bundled dress painted stiff all over
(every triangle drawn), at two mesh densities.

    .venv/bin/python benchmarks/bench_heatmap.py [--frames 40]

Each figure is the median frame time of ``--frames`` frames, each after a pointer move.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import pyglet  # noqa: E402

pyglet.options["headless"] = True

import numpy as np  # noqa: E402


def frame_ms(d, frames: int) -> float:
    out = []
    for i in range(frames):
        d.w.win.dispatch_event("on_mouse_motion", 300 + i % 50, 300, 1, 0)
        t = time.perf_counter()
        d.frame()
        out.append((time.perf_counter() - t) * 1000)
    return statistics.median(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=40)
    args = ap.parse_args()
    from tests.app.harness import Driver

    print(f"load {os.getloadavg()[0]:.1f}")
    print(f"{'max_area':>9} {'triangles':>9} {'off ms':>7} {'heat ms':>8}")
    for area in (40.0, 8.0):
        d = Driver(os.path.join(ROOT, "assets", "scenes", "dress-garment.json"), size=(1000, 760))
        try:
            d.app.edit(lambda s, a=area: s.set_mesh_options("dress", max_area=a))
            d.app.edit(lambda s: s.set_stiffness_pixels("dress", np.full((512, 512), 200)))
            d.settle()
            row = []
            for on in (False, True):
                d.app.show_stiffness = on
                d.frame(3)
                row.append(frame_ms(d, args.frames))
            n = len(d.app.snap.layers[0].triangles)
            print(f"{area:9.0f} {n:9d} {row[0]:7.1f} {row[1]:8.1f}")
        finally:
            d.close()


if __name__ == "__main__":
    main()
