"""Cage coordinates (puppet.deform.cage): precompute and one pose of a 20k-vertex layer
inside a 24-vertex automatic cage, for each kind. CPU time (process time), one BLAS
thread, best of several runs; the issue's targets: a pose <= 5 ms, the harmonic
precompute <= 2 s. Prints a table."""
from __future__ import annotations

import os
import time

import numpy as np
from threadpoolctl import threadpool_limits

from puppet.deform.cage import KINDS, CageMap, auto_cage, fit_cage


def layer(n_target: int = 20_000):
    """An ellipse mask (480 x 320 px) and about ``n_target`` mesh vertices on a grid inside it."""
    H, W = 360, 520
    yy, xx = np.mgrid[0:H, 0:W]
    mask = ((xx - 260) / 240.0) ** 2 + ((yy - 180) / 160.0) ** 2 <= 1.0
    step = np.sqrt(mask.sum() / n_target)
    gy, gx = np.mgrid[0:H:step, 0:W:step]
    P = np.c_[gx.ravel(), gy.ravel()]
    inside = ((P[:, 0] - 260) / 240.0) ** 2 + ((P[:, 1] - 180) / 160.0) ** 2 <= 1.0
    return mask, P[inside]


def cpu_best(fn, repeat: int):
    """Smallest CPU time of ``repeat`` calls, seconds; the last result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t)
    return best, out


def main():
    mask, X = layer()
    C = auto_cage(mask, 24, 12.0)
    rng = np.random.default_rng(0)
    posed = C + rng.normal(0.0, 8.0, C.shape)
    pins = X[rng.choice(len(X), 5, replace=False)]
    print(f"load average {os.getloadavg()[0]:.2f}; {len(X)} points, cage of {len(C)} vertices")
    print(f"{'kind':<10}{'precompute s':>14}{'pose ms':>10}{'fit 5 pins ms':>15}")
    with threadpool_limits(1):
        for kind in KINDS:
            t_pre, cm = cpu_best(lambda: CageMap(C, X, kind), 2)
            t_pose, _ = cpu_best(lambda: cm.apply(posed), 200)
            pm = CageMap(C, pins, kind)
            t_fit, _ = cpu_best(lambda: fit_cage(C, kind, pins, pins + 5.0, cage_map=pm), 20)
            print(f"{kind:<10}{t_pre:>14.3f}{t_pose * 1e3:>10.3f}{t_fit * 1e3:>15.2f}")


if __name__ == "__main__":
    main()
