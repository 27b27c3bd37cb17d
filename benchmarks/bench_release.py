"""The exact solve a release runs, against vertices: default (20 plain ARAP iterations
from the MLS guess) against Anderson acceleration to a tolerance (issue 31).

The bundled T-rex (``assets/scenes/trex-layers.json``, 8 linked layers) is meshed denser
(every layer's ``mesh.max_area`` scaled, at least the format's 0.5) to about 2k, 8k,
32k, 60k and 128k vertices (the last stops near 96k: the areas reach 0.5);
``--psd SCENE`` adds a scene of your own (the 20-part 4K PSD of ``bench_import.make_psd``
after ``puppet init --pins auto --links auto``). In each, the pin nearest the middle of
the biggest group moves by ``--drag`` px (60), and the table gives:

* ``release (default)``: wall and CPU time (ms) of the default exact solve
  (``solve_group``: MLS guess, 20 iterations, fold relaxation), median of ``--repeat``,
  and its ARAP energy's relative gap above the converged pose, ``(E - E*) / E*`` (E*:
  the lowest energy Anderson reaches, tolerance 1e-6 px);
* plain and Anderson iterations to ``--tol`` px (no vertex moving more in a plain
  step; ``>N`` = not reached in ``--cap``), their CPU time and Anderson's gap;
* ``AA warm``: Anderson to ``--tol`` from the last preview of a drag to the pose in ten
  frames of 4 warm-started iterations (the opted-in release's start);
* ``release (AA)``: the whole exact solve opted in (``deformer.accelerate: "anderson"``,
  ``tolerance`` ``--tol``, ``iterations`` ``--cap``), cold from the MLS guess, fold
  relaxation included.

CPU times (``time.process_time``: both solver threads) are what to compare on a busy
machine; the load average is printed with the table. Run:
``python benchmarks/bench_release.py --psd /path/s.json``.
"""
from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace

import numpy as np

import puppet
from puppet.deform.anderson import WINDOW, arap_solve_anderson
from puppet.deform.arap import arap_energy
from puppet.scene.rig.build import layer_areas
from puppet.scene.rig.solve import preview_group, solve_group

HERE = os.path.dirname(os.path.abspath(__file__))
TREX = os.path.join(HERE, "..", "assets", "scenes", "trex-layers.json")


def meshed(path: str, vertices: int | None):
    """The scene with every layer's triangle area scaled for about ``vertices`` vertices."""
    scene = puppet.load_scene(path)
    if vertices is None:
        return scene
    built = scene.built
    n = sum(len(g.mesh.V) for g in built.groups)
    for L, area in zip(scene.data.layers, layer_areas(scene.data, built.images)):
        scene.set_mesh_options(L.name, max_area=max(float(area) * n / vertices, 0.5))  # the format's least
    return scene


def case(scene, drag: float):
    """(solve_group arguments, ArapData, targets) of a drag of the middle pin of the
    biggest group by ``drag`` px."""
    built = scene.built
    gi = max(range(len(built.groups)), key=lambda i: len(built.groups[i].mesh.V))
    g = built.groups[gi]
    V = g.mesh.V
    mid = V.mean(axis=0)
    pins = list(g.pins)
    i = pins[int(np.argmin([np.linalg.norm(V[g.b[k]] - mid) for k in range(len(pins))]))]
    state = scene.state()
    state.to[i] += drag * np.array([0.8, -0.6])
    pose = built.group_pose(gi, state)
    args = (built.pre[gi], g, scene.data.deformer, built.exterior[gi], pose)
    return args, built.pre[gi].arap, pose.bc


def dragged(args, frames: int = 10) -> np.ndarray:
    """The last preview of the group after a drag from rest to the pose in ``frames``
    preview frames (``preview_group``: 4 iterations warm-started from the frame before)."""
    pre, g, d, ext, pose = args
    rest = g.mesh.V[g.b]
    U = g.mesh.V.copy()
    for k in range(1, frames + 1):
        U = preview_group(pre, g, d, ext, replace(pose, bc=rest + (pose.bc - rest) * k / frames), U)[0]
    return U


def timed(fn, repeat: int):
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return 1e3 * float(np.median(walls)), 1e3 * float(np.median(cpus)), out


def row(name: str, scene, repeat: int, tol: float, cap: int, drag: float) -> str:
    args, a, bc = case(scene, drag)
    solve_group(*args)  # weights of the MLS guess computed once, as after a first render
    wall, cpu, (U, _, _) = timed(lambda: solve_group(*args), repeat)
    ref = arap_solve_anderson(a, bc, iterations=4 * cap, tolerance=1e-6)[1]
    e_star = min(ref.energies)
    cells = [f"{wall:6.0f} {cpu:6.0f} {(arap_energy(a, U) - e_star) / e_star:8.1e}"]
    for window in (0, WINDOW):
        c0 = time.process_time()
        Uw, info = arap_solve_anderson(a, bc, iterations=cap, tolerance=tol, window=window)
        ms = 1e3 * (time.process_time() - c0)
        its = f"{info.iterations}" if info.converged else f">{info.iterations}"
        cells.append(f"{its:>5} {ms:7.0f}" + (f" {(arap_energy(a, Uw) - e_star) / e_star:8.1e}" if window else ""))
    start = dragged(args)
    c0 = time.process_time()
    info = arap_solve_anderson(a, bc, iterations=cap, tolerance=tol, U0=start)[1]
    its = f"{info.iterations}" if info.converged else f">{info.iterations}"
    cells.append(f"{its:>5} {1e3 * (time.process_time() - c0):7.0f}")
    fast = replace(args[2], accelerate="anderson", tolerance=tol, iterations=cap)
    wall, cpu, _ = timed(lambda: solve_group(args[0], args[1], fast, *args[3:]), repeat)
    cells.append(f"{wall:6.0f} {cpu:6.0f}")
    return f"{name:>10} {a.n:>7} {len(a.b):>4} " + "  ".join(cells)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2000,8000,32000,60000,128000", help="T-rex vertex counts ('' for none)")
    ap.add_argument("--psd", action="append", default=[], help="another scene (repeatable)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tol", type=float, default=0.01, help="px")
    ap.add_argument("--cap", type=int, default=300, help="most iterations of the to-tolerance runs")
    ap.add_argument("--drag", type=float, default=60.0, help="how far the pin moves, px")
    o = ap.parse_args()
    print(f"load average at start {os.getloadavg()[0]:.2f}; drag {o.drag:g} px; tolerance {o.tol} px; cap {o.cap}")
    print(f"{'':>23} {'release (default)':^22}  {'plain to tol':^13}  {'Anderson to tol':^22}  "
          f"{'AA warm':^13}  {'release (AA)':^13}")
    print(f"{'scene':>10} {'verts':>7} {'pins':>4} {'wall':>6} {'cpu':>6} {'gap':>8}  {'its':>5} {'cpu':>7}  "
          f"{'its':>5} {'cpu':>7} {'gap':>8}  {'its':>5} {'cpu':>7}  {'wall':>6} {'cpu':>6}")
    cases = [(f"trex-{int(s) // 1000}k", TREX, int(s)) for s in o.sizes.split(",") if s]
    cases += [(os.path.basename(p)[:10], p, None) for p in o.psd]
    for name, path, n in cases:
        print(row(name, meshed(path, n), o.repeat, o.tol, o.cap, o.drag), flush=True)
    print(f"load average at end {os.getloadavg()[0]:.2f} (times in ms; cpu = process CPU time, both solver threads)")


if __name__ == "__main__":
    main()
