"""Dragging through the API (``scene.drag(...)``): time per preview frame (``d.move``,
composited at the bounded preview size) and of the exact release (``d.release``, full
size), for a single pin, 3 pins and a key drag on the T-rex (8 linked layers, 7.7k
vertices) and on a 4000x4000 garment photo (the bundled t-shirt emoji upscaled and put
through ``puppet init --alpha --pins auto``, 17.7k vertices), with the solve alone
(``d.move_layers``) and two floors measured in the same run: a plain single-pass draw of
the same meshes at the preview size, read back, and a fixed numpy workload (the load).

    .venv/bin/python benchmarks/bench_drag.py [--steps 60]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import puppet  # noqa: E402

SCENES = os.path.join(ROOT, "assets", "scenes")


def garment_4k(folder: str) -> str:
    """A 4000x4000 garment photo scene: the t-shirt emoji upscaled, ``puppet init --pins auto``."""
    from PIL import Image

    from puppet.scene.make.picture import init_scene

    image = os.path.join(folder, "shirt4k.png")
    Image.open(os.path.join(ROOT, "assets", "noto-emoji", "emoji_u1f455.png")).convert("RGBA").resize(
        (4000, 4000), Image.BICUBIC).save(image)
    path = os.path.join(folder, "shirt4k.json")
    init_scene(image, path, rule="alpha", pins="auto")
    return path


def load_floor() -> float:
    """Median time (ms) of a fixed numpy workload: what the machine's load does to a core."""
    a = np.random.default_rng(0).normal(size=(200, 200))
    times = []
    for _ in range(9):
        t0 = time.perf_counter()
        for _ in range(20):
            np.sort(a, axis=0)
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))


def key_drag(scene, names, t):
    """A key drag at ``t``, the frame at ``t`` shown first (as the app shows it)."""
    if scene.data.animation is not None:
        scene.layers(time=t)
    return scene.drag(names, time=t)


def kinds(scene, names3):
    """(label, drag(), targets(k)) of the three drag kinds over ``names3`` (first: the single pin)."""
    at = {p.name: np.asarray(p.at, float) for p in scene.data.pins}

    def loop(k, n):
        a = 2 * np.pi * k / n
        return np.array([np.sin(a), (1 - np.cos(a)) * 0.6])
    t = 0.75 if scene.data.animation is not None else 0.5
    return [
        ("single pin", lambda: scene.drag(names3[0]), lambda k, n, r: {names3[0]: at[names3[0]] + r * loop(k, n)}),
        ("3 pins", lambda: scene.drag(names3), lambda k, n, r: {m: at[m] + r * loop(k + i, n)
                                                                  for i, m in enumerate(names3)}),
        (f"key at {t:g} s", lambda: key_drag(scene, names3[:2], t),
         lambda k, n, r: {m: at[m] + r * loop(k, n) for m in names3[:2]}),
    ]


def run(path: str, names3: list[str], steps: int, radius: float) -> list[dict]:
    scene = puppet.load_scene(path)
    scene.render()  # build, precompute, upload textures
    nv = sum(len(g.mesh.V) for g in scene.built.groups)
    rows = []
    for label, start, targets in kinds(scene, names3):
        d = start()
        moves, solves = [], []
        for k in range(steps):
            t0 = time.perf_counter()
            d.move(targets(k, steps, radius))
            moves.append(time.perf_counter() - t0)
        for k in range(20):
            t0 = time.perf_counter()
            d.move_layers(targets(k, 20, radius))
            solves.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        d.release()
        release = time.perf_counter() - t0
        scene.undo()
        ms = 1000 * np.asarray(moves)
        rows.append({"scene": os.path.basename(path), "kind": label, "vertices": nv,
                     "preview": "%dx%d" % d.preview_size, "move_med": np.median(ms), "move_p90": np.percentile(ms, 90),
                     "solve": 1000 * np.median(solves), "release": 1000 * release})
    floor = floor_draw(scene, scene.layers(), rows[0]["preview"])
    for r in rows:
        r["floor"] = floor
    scene.close()
    return rows


def floor_draw(scene, layers, size: str) -> float:
    """Median time (ms) of a plain single-pass depth-tested textured draw of the layers at
    ``size`` ("WxH"), read back."""
    from benchmarks.bench_render import Floor
    from puppet.render.layers import DrawLayer

    wh = tuple(int(v) for v in size.split("x"))
    draw = [DrawLayer(r.name, im.rgba, im.offset, r.rest, r.deformed, r.triangles, r.depth)
            for r, im in zip(layers, scene.built.images)]
    floor = Floor(scene.compositor.ctx, draw, wh)
    times = []
    for _ in range(15):
        t0 = time.perf_counter()
        floor.draw(draw, wh)
        floor.fbo.read(components=4)
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))


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
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args()
    from threadpoolctl import threadpool_info

    blas = [(i["internal_api"], i["num_threads"]) for i in threadpool_info()]
    print(f"BLAS pools: {blas}; load average {os.getloadavg()[0]:.2f}; numpy floor {load_floor():.1f} ms "
          "(the load: ~1.3 ms when a core is free)")
    with tempfile.TemporaryDirectory() as tmp:
        rows = run(os.path.join(SCENES, "trex-layers.json"), ["hand_front", "tail_tip", "jaw"], args.steps, 40.0)
        rows += run(garment_4k(tmp), ["end1", "end3", "joint1"], args.steps, 120.0)
    print(f"load average after: {os.getloadavg()[0]:.2f}; numpy floor {load_floor():.1f} ms")
    print(f"\n{'scene':18s} {'drag':12s} {'verts':>6s} {'preview':>9s} {'move med':>9s} {'move p90':>9s} "
          f"{'solve':>6s} {'release':>8s} {'floor':>6s}   (ms; targets: move med <= 40 on the garment)")
    for r in rows:
        print(f"{r['scene']:18s} {r['kind']:12s} {r['vertices']:6d} {r['preview']:>9s} {r['move_med']:9.1f} "
              f"{r['move_p90']:9.1f} {r['solve']:6.1f} {r['release']:8.1f} {r['floor']:6.1f}")
    load, edit, rebuilt = edit_cost(os.path.join(SCENES, "trex-layers.json"), "toparm")
    print(f"\nT-rex: full load {load:.0f} ms; mesh options of one layer {edit:.0f} ms = {edit / load:.2f}x "
          f"(target <= 0.5x); rebuilt: {rebuilt}")


if __name__ == "__main__":
    main()
