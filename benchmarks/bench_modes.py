"""Deformation modes (issue 22): solve time of each mode against rigid ARAP.

Run:  python benchmarks/bench_modes.py [--runs 2]
Meshes: quality discs of about 5k and 20k vertices, five pins (benchmarks.common). Per
mode: the precomputation (factorisation + operators) and a pose solve = initial guess +
20 local/global iterations, as `puppet.scene.rig.solve` runs it: `similar` starts from the
pins' least-squares similarity then MLS (garment fitting), its cells' scale bounded
around that similarity's; `rigid+paint` has
cell weights 1..100 over a third of the disc. The ratio columns are solve / rigid solve, by wall time (best of 9) and by process CPU
time (best of 9, all threads: less moved by the other processes of a shared machine).
The table is printed once per run, with the load average and the BLAS threads.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from benchmarks.common import best, disc, pins_and_targets  # noqa: E402

from puppet.deform.arap import arap_precompute, arap_solve  # noqa: E402
from puppet.deform.mls import mls_object_space  # noqa: E402
from puppet.deform.modes import (SCALE_SPAN, apply_similarity, mode_mix, similarity_fit,  # noqa: E402
                                 stiffness_from_grey)

SIZES = {"5k": (500, 6.0), "20k": (1000, 1.5)}


def solve(data, bc, prefit):
    """A pose as puppet.scene.rig.solve runs it: in `similar`, the similarity guess and the
    cells' scale bounded around the pins' similarity scale."""
    if not prefit:
        return arap_solve(data, bc)  # its own MLS guess
    s, t = similarity_fit(data.V[data.b], bc)
    V = apply_similarity(data.V, s, t)
    U0 = mls_object_space(V, data.D, bc, V[data.b], kind="rigid", alpha=data.alpha)
    return arap_solve(data, bc, U0=U0, scale=(abs(s) / SCALE_SPAN, abs(s) * SCALE_SPAN))


def cases(V):
    n = len(V)
    grey = np.where(V[:, 0] > 33, 255.0 * np.clip((V[:, 0] - 33) / 30, 0, 1), 0.0)
    return [("rigid", {}, False),
            ("similar", {"mix": mode_mix(["similar"] * n)}, True),
            ("distort", {"mix": mode_mix(["distort"] * n)}, False),
            ("rigid+paint", {"stiffness": stiffness_from_grey(grey)}, False),
            ("similar+paint", {"mix": mode_mix(["similar"] * n, grey / 255), "stiffness": stiffness_from_grey(grey)},
             True)]


def cpu_best(fn, repeat=9):
    """Best process CPU time (all threads) of ``repeat`` calls, in seconds: less moved by
    other processes on a shared machine than the wall time."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def table():
    rows = []
    for size, (nb, area) in SIZES.items():
        V, F = disc(nb, area)
        b, bc = pins_and_targets(V)
        base = None
        for name, kw, prefit in cases(V):
            t_pre, data = best(lambda: arap_precompute(V, F, b, **kw), repeat=3)
            t_solve, _ = best(lambda: solve(data, bc, prefit), repeat=9)
            c_solve = cpu_best(lambda: solve(data, bc, prefit))
            if name == "rigid":
                base, cbase = t_solve, c_solve
            rows.append((size, len(V), name, t_pre * 1e3, t_solve * 1e3, t_solve / base, c_solve * 1e3,
                         c_solve / cbase))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2)
    args = ap.parse_args()
    try:
        from threadpoolctl import threadpool_info

        blas = ", ".join(f"{i['internal_api']} {i['num_threads']} threads" for i in threadpool_info())
    except ImportError:
        blas = "threadpoolctl not installed"
    for run in range(args.runs):
        load = os.getloadavg()
        print(f"\nrun {run + 1}: load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; {os.cpu_count()} CPUs; "
              f"BLAS: {blas}")
        print("| mesh | vertices | mode | precompute ms | solve ms (wall) | / rigid | solve ms (CPU) | / rigid |")
        print("|---|---:|---|---:|---:|---:|---:|---:|")
        for size, n, name, tp, ts, ratio, cs, cratio in table():
            print(f"| {size} | {n} | {name} | {tp:.1f} | {ts:.1f} | {ratio:.2f} | {cs:.1f} | {cratio:.2f} |")


if __name__ == "__main__":
    main()
