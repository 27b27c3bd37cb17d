"""BLAS threads in the solvers: default pools, capped per solve, capped process-wide.

Run:  python benchmarks/bench_threads.py [--rounds R]
Three settings, interleaved round by round in one process so that they see the same
machine load: "BLAS pools" (``puppet.deform.threads.BLAS_THREADS = None``, OpenBLAS uses
every core), "per solve" (the default: each solve entry point caps BLAS at one thread
and restores it), "process-wide" (one ``threadpool_limits(1)`` for the whole process,
no per-call cost). Rows: a full ARAP pose (MLS guess + 20 iterations) at 5k and 20k
vertices, image-space rigid MLS over 512x512 points with 10 controls, and the skinny
product ``W^T M`` (W 5 x 20k) alone. ms, median and best of each round's calls.
On 2 cores the result depends on what else runs: BLAS threads hurt most when the
machine is busy (run it next to another job to see it).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from benchmarks.common import disc, pins_and_targets  # noqa: E402

import puppet.deform.threads as threads  # noqa: E402
from puppet.deform import arap_precompute, arap_solve, mls_deform  # noqa: E402


def timed(fn, repeat):
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts)), min(ts)


def tasks():
    out = {}
    for label, spec in (("5k", (240, 5.0)), ("20k", (480, 1.25))):
        V, F = disc(*spec)
        b, bc = pins_and_targets(V)
        data = arap_precompute(V, F, b)
        out[f"arap pose {label} ({len(V)} v)"] = ((lambda d=data, t=bc: arap_solve(d, t)), 9)
    g = np.mgrid[0:512, 0:512].reshape(2, -1).T.astype(float)
    rng = np.random.default_rng(0)
    p = rng.uniform(0, 512, (10, 2))
    q = p + rng.normal(scale=20, size=p.shape)
    out["mls_deform 512x512"] = ((lambda: mls_deform(g, p, q)), 5)
    W, M = rng.random((5, 20000)), rng.random((5, 8))
    def product():
        if threads.BLAS_THREADS is None:
            return W.T @ M
        with threads.one_blas_thread():  # as inside a solve
            return W.T @ M
    out["W^T M, W 5 x 20k"] = (product, 30)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    from threadpoolctl import threadpool_info, threadpool_limits

    work = tasks()
    modes = ("BLAS pools", "per solve", "process-wide")
    res = {name: {m: [] for m in modes} for name in work}
    for _ in range(args.rounds):
        for mode in modes:
            threads.BLAS_THREADS = None if mode != "per solve" else 1
            limiter = threadpool_limits(1, user_api="blas") if mode == "process-wide" else None
            for name, (fn, repeat) in work.items():
                res[name][mode].append(timed(fn, repeat))
            if limiter is not None:
                limiter.restore_original_limits()
    threads.BLAS_THREADS = 1
    pools = [f"{p['internal_api']} {p['num_threads']} threads" for p in threadpool_info()
             if p["user_api"] == "blas"]
    print(f"{os.cpu_count()} cores; BLAS: {', '.join(pools)}; "
          f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE', '(unset)')}")
    print("ms, median / best per round\n")
    width = max(len(n) for n in work) + 2
    cells = {name: ["  ".join(f"{1e3 * a:.2f}/{1e3 * b:.2f}" for a, b in res[name][m]) for m in modes]
             for name in work}
    cw = max(len(c) for row in cells.values() for c in row) + 3
    print("".ljust(width) + "".join(m.rjust(cw) for m in modes))
    for name in work:
        print(name.ljust(width) + "".join(c.rjust(cw) for c in cells[name]))


if __name__ == "__main__":
    main()
