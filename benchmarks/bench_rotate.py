"""Pins with an angle: arap_solve vs arap_solve_rotated on a ~5k-vertex puppet.

Run:  python benchmarks/bench_rotate.py
The shape is a body bar with a neck and a head block (scaled x3), pins at the hip, the
chest and inside the head; the head pin turns by the listed angle (on-screen degrees).
Columns: wall time (best of 3), the time of the full pass alone (rounds=0), the held
cells, and per residual round the free vertices of the re-solved block and the time
to factorise it; "turn" is the Procrustes angle of the vertices near the head pin.
"""
from __future__ import annotations

import os
import sys

import numpy as np
import triangle

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from benchmarks.common import best  # noqa: E402

from puppet.deform import arap_precompute, arap_solve  # noqa: E402
from puppet.deform.rotate import arap_solve_rotated  # noqa: E402

SCALE = 3.0


def puppet_mesh(max_area: float):
    pts = SCALE * np.array([[0, 20], [26, 20], [26, 14], [20, 14], [20, 0], [38, 0], [38, 14],
                            [32, 14], [32, 20], [40, 20], [40, 30], [0, 30]], float)
    seg = np.c_[np.arange(len(pts)), (np.arange(len(pts)) + 1) % len(pts)]
    T = triangle.triangulate({"vertices": pts, "segments": seg}, f"pq30a{max_area}")
    return T["vertices"], T["triangles"].astype(np.int64)




def screen_angle(V0, U, mask):
    X, Y = V0[mask] - V0[mask].mean(0), U[mask] - U[mask].mean(0)
    return -np.degrees(np.arctan2((X[:, 0] * Y[:, 1] - X[:, 1] * Y[:, 0]).sum(), (X * Y).sum()))


def main():
    V, F = puppet_mesh(1.0)
    spots = SCALE * np.array([[3, 25], [20, 25], [29, 9]])
    b = np.array([np.argmin(np.linalg.norm(V - s, axis=1)) for s in spots])
    bc = V[b] + SCALE * np.array([[-2.0, 3.0], [1.0, -1.0], [2.0, 1.0]])
    t_pre, data = best(lambda: arap_precompute(V, F, b))
    t_arap, U0 = best(lambda: arap_solve(data, bc, iterations=20))
    near_pin = np.linalg.norm(V - V[b[2]], axis=1) < 4 * SCALE
    print(f"mesh: {len(V)} vertices, {len(F)} triangles; factor {data.factor.kind}; "
          f"precompute {1e3 * t_pre:.1f} ms; times in ms, best of 3, 20 iterations\n")
    head = (f"{'solve':28s} {'total':>7s} {'pass':>7s} {'held':>5s} {'turn':>7s}  "
            "rounds: free vertices / factorise ms")
    print(head)
    print("-" * len(head))
    print(f"{'arap_solve':28s} {1e3 * t_arap:7.2f}")
    for theta in (0.0, 20.0, -30.0, 45.0):
        ang = np.array([0.0, 0.0, theta])
        info = {}
        t_rot, U = best(lambda: arap_solve_rotated(data, bc, ang, info=info))
        t_pass, _ = best(lambda: arap_solve_rotated(data, bc, ang, rounds=0))
        rounds = "  ".join(f"{r['free']}/{1e3 * r['factor_s']:.2f}" for r in info["rounds"])
        print(f"{f'arap_solve_rotated {theta:+.0f} deg':28s} {1e3 * t_rot:7.2f} "
              f"{1e3 * t_pass:7.2f} {info['held']:5d} {screen_angle(V, U, near_pin):7.2f}  "
              f"{rounds or '-'}")


if __name__ == "__main__":
    main()
