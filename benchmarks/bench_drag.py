"""Dragging a pin: time per preview frame (`Drag.move`) and of the exact final frame
(`Drag.release`), on the T-rex (8 linked layers, 7.7k vertices) and on a one-layer
~10k-vertex horse, at the scene's canvas size, with the parts of a move (solve,
composite) and the floor (a plain single-pass depth-tested draw of the same meshes at
the same size, measured in the same run).

    .venv/bin/python benchmarks/bench_drag.py [--steps 120]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import puppet  # noqa: E402

SCENES = os.path.join(ROOT, "assets", "scenes")


def horse_10k(folder: str) -> str:
    """The horse scene with a mesh fine enough for ~10k vertices."""
    with open(os.path.join(SCENES, "horse.json")) as f:
        doc = json.load(f)
    doc["source"] = os.path.normpath(os.path.join(SCENES, doc["source"]))
    doc["layers"][0]["mesh"] = {"max_area": 3.4}
    path = os.path.join(folder, "horse10k.json")
    with open(path, "w") as f:
        json.dump(doc, f)
    return path


def drag_path(start, steps: int, radius: float) -> np.ndarray:
    """A loop out from the pin and back: ``steps`` points."""
    t = np.linspace(0, 2 * np.pi, steps)
    return np.asarray(start) + radius * np.c_[np.sin(t), (1 - np.cos(t)) * 0.6]


def floor_draw(scene, layers) -> float:
    """Median time of a plain single-pass depth-tested textured draw of the layers, read back."""
    from benchmarks.bench_render import Floor
    from puppet.render.layers import DrawLayer

    draw = [DrawLayer(r.name, im.rgba, im.offset, r.rest, r.deformed, r.triangles, r.depth)
            for r, im in zip(layers, scene.built.images)]
    floor = Floor(scene.compositor.ctx, draw, scene.canvas)
    times = []
    for _ in range(15):
        t0 = time.perf_counter()
        floor.draw(draw, scene.canvas)
        floor.fbo.read(components=4)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def run(path: str, pin: str, steps: int, radius: float) -> dict:
    scene = puppet.load_scene(path)
    scene.render()  # build, precompute, upload textures
    nv = sum(len(g.mesh.V) for g in scene.built.groups)
    i = [p.name for p in scene.data.pins].index(pin)
    pts = drag_path(scene.data.pins[i].at, steps, radius)
    d = scene.drag(pin)
    moves, solves = [], []
    for xy in pts:
        t0 = time.perf_counter()
        d.move(xy)
        moves.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    d.release()
    release = time.perf_counter() - t0
    # the parts of one move, measured apart
    d = scene.drag(pin)
    d.move(pts[1])
    for xy in pts[:30]:
        t0 = time.perf_counter()
        d._state.to[d._index] = xy
        d._U = scene.rig.preview(d._built, d._group, d._state, d._U, iterations=d.iterations)[0]
        solves.append(time.perf_counter() - t0)
    d.cancel()
    layers = scene.layers()
    comp = []
    for _ in range(15):
        t0 = time.perf_counter()
        scene.draw_layers(layers)
        comp.append(time.perf_counter() - t0)
    try:
        floor = floor_draw(scene, layers)
    except ImportError:
        floor = float("nan")
    scene.close()
    ms = 1000 * np.asarray(moves)
    return {"scene": os.path.basename(path), "vertices": nv, "size": "%dx%d" % scene.canvas,
            "move_med": np.median(ms), "move_p95": np.percentile(ms, 95), "release": 1000 * release,
            "solve": 1000 * np.median(solves), "composite": 1000 * np.median(comp), "floor": 1000 * floor}


def edit_cost(path: str, layer: str) -> tuple[float, float, dict]:
    """Median times (ms) of a full load (images, meshes, precompute) and of one layer's
    mesh-option edit, and the parts that edit rebuilt."""
    loads, edits = [], []
    for k in range(3):
        t0 = time.perf_counter()
        scene = puppet.load_scene(path)
        scene.built
        loads.append(time.perf_counter() - t0)
        before = dict(scene.rig.memo.builds)
        t0 = time.perf_counter()
        scene.set_mesh_options(layer, max_area=40.0 + k)
        edits.append(time.perf_counter() - t0)
        rebuilt = {kind: n - before.get(kind, 0) for kind, n in scene.rig.memo.builds.items()
                   if n != before.get(kind, 0)}
    return 1000 * float(np.median(loads)), 1000 * float(np.median(edits)), rebuilt


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=120)
    args = ap.parse_args()
    from threadpoolctl import threadpool_info

    blas = [(i["internal_api"], i["num_threads"]) for i in threadpool_info()]
    print(f"BLAS pools: {blas}; LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', 'unset')}")
    with tempfile.TemporaryDirectory() as tmp:
        rows = [run(os.path.join(SCENES, "trex-layers.json"), "hand_front", args.steps, 40.0),
                run(horse_10k(tmp), "front_hoof_a", args.steps, 60.0)]
    print(f"\n{'scene':22s} {'verts':>6s} {'size':>8s} {'move med':>9s} {'move p95':>9s} {'release':>8s} "
          f"{'solve':>6s} {'compos.':>8s} {'floor':>6s}   (ms; targets: move med <= 33, p95 <= 50, "
          "release <= 150)")
    for r in rows:
        print(f"{r['scene']:22s} {r['vertices']:6d} {r['size']:>8s} {r['move_med']:9.1f} {r['move_p95']:9.1f} "
              f"{r['release']:8.1f} {r['solve']:6.1f} {r['composite']:8.1f} {r['floor']:6.1f}")
    load, edit, rebuilt = edit_cost(os.path.join(SCENES, "trex-layers.json"), "toparm")
    print(f"\nT-rex: full load {load:.0f} ms; mesh options of one layer {edit:.0f} ms = {edit / load:.2f}x "
          f"(target <= 0.5x); rebuilt: {rebuilt}")


if __name__ == "__main__":
    main()
