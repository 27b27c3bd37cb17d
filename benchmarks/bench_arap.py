"""ARAP timings: puppet (numpy + scipy + cholespy) vs libigl's C++ ARAP (SPOKES).

Run:  python benchmarks/bench_arap.py
Needs `triangle`; the libigl columns appear when `import igl` works (pip install libigl).
Both sides get the same disc mesh, the same 5 pins and targets, and for the iteration
comparison the same start (puppet's object-space MLS guess); the energy of both results
is evaluated with puppet's `arap_energy` (libigl's cotangent weights are the same).
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np
import triangle

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import puppet.deform.arap as arap_mod  # noqa: E402
from puppet.deform import arap_energy, arap_precompute, arap_solve  # noqa: E402

try:
    import igl
except ImportError:  # libigl is an optional benchmark dependency
    igl = None


def disc(n_boundary: int, max_area: float, radius: float = 100.0):
    t = np.linspace(0, 2 * np.pi, n_boundary, endpoint=False)
    pts = radius * np.c_[np.cos(t), np.sin(t)]
    seg = np.c_[np.arange(n_boundary), (np.arange(n_boundary) + 1) % n_boundary]
    T = triangle.triangulate({"vertices": pts, "segments": seg}, f"pq30a{max_area}")
    return T["vertices"], T["triangles"].astype(np.int64)


def pins_and_targets(V):
    spots = np.array([[0, 0], [70, 0], [-70, 0], [0, 70], [0, -70]], float)
    b = np.array([np.argmin(np.linalg.norm(V - s, axis=1)) for s in spots])
    bc = V[b] + np.array([[0, 0], [25, -30], [-10, 15], [20, 10], [-15, -5]], float)
    return b, bc


def best(fn, repeat=3):
    """Best wall time of `repeat` calls, in seconds, and the last result."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def igl_data(V, F, b, max_iter):
    d = igl.ARAPData()
    d.energy = igl.ARAPEnergyType.ARAP_ENERGY_TYPE_SPOKES
    d.max_iter = max_iter
    igl.arap_precomputation(V, F, 2, b.astype(np.int32), d)
    return d


def bench_mesh(label, V, F, rows, diffs):
    b, bc = pins_and_targets(V)
    t_pre, data = best(lambda: arap_precompute(V, F, b))
    U0 = arap_solve(data, bc, iterations=0)  # MLS initial guess, pins at targets
    t_it, _ = best(lambda: arap_solve(data, bc, iterations=10, U0=U0))
    t_pose, U = best(lambda: arap_solve(data, bc, iterations=20))
    r = {"mesh": label, "pre": (t_pre, None), "it": (t_it / 10, None), "pose": (t_pose, None)}
    if igl is not None:
        Vc, Fc = np.ascontiguousarray(V), np.ascontiguousarray(F)
        ti_pre, _ = best(lambda: igl_data(Vc, Fc, b, 20))
        d10 = igl_data(Vc, Fc, b, 10)
        ti_it, _ = best(lambda: igl.arap_solve(bc, d10, U0))
        d20 = igl_data(Vc, Fc, b, 20)
        ti_pose, Ui = best(lambda: igl.arap_solve(bc, d20, U0))
        r["pre"] = (t_pre, ti_pre)
        r["it"] = (t_it / 10, ti_it / 10)
        r["pose"] = (t_pose, ti_pose)
        Up = arap_solve(data, bc, iterations=20, U0=U0)  # same start, same count
        Ep, Ei = arap_energy(data, Up), arap_energy(data, Ui)
        diffs.append((label, np.abs(Up - Ui).max(), Ep, Ei))
    rows.append(r)
    return data


def bench_factor(label, data, out):
    from puppet.deform.arap import _CholespyFactor, _SpluFactor

    A = data.L[data.free][:, data.free].tocsc()
    rhs = np.random.default_rng(0).normal(size=(A.shape[0], 2))
    for cls in (_CholespyFactor, _SpluFactor):
        t_f, fac = best(lambda: cls(A))
        t_s, _ = best(lambda: [fac.solve(rhs) for _ in range(20)])
        out.append((label, cls.kind, t_f, t_s / 20))


def igl_version():
    if igl is None:
        return "not installed (pip install libigl)"
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("libigl")
    except PackageNotFoundError:
        return "installed"


def fmt_ms(t):
    return "      -" if t is None else f"{1e3 * t:7.2f}"


def main():
    meshes = [("disc", 240, 5.0), ("disc", 480, 1.25)]
    rows, diffs, facs = [], [], []
    for name, nb, area in meshes:
        V, F = disc(nb, area)
        label = f"{name} {len(V) // 1000}k ({len(V)} v, {len(F)} t)"
        data = bench_mesh(label, V, F, rows, diffs)
        bench_factor(label, data, facs)
    print(f"puppet ARAP (primary factoriser: {data.factor.kind}); libigl: {igl_version()}")
    print("times in ms, best of 3; 'iteration' = average of 10; pose = MLS init + 20 "
          "iterations (libigl: 20 iterations from the same MLS start)\n")
    head = f"{'mesh':34s} {'step':12s} {'puppet':>8s} {'libigl':>8s} {'ratio':>7s}"
    print(head)
    print("-" * len(head))
    for r in rows:
        for key, name in (("pre", "precompute"), ("it", "iteration"), ("pose", "full pose")):
            tp, ti = r[key]
            ratio = f"{tp / ti:7.2f}" if ti else "      -"
            print(f"{r['mesh']:34s} {name:12s} {fmt_ms(tp)} {fmt_ms(ti)} {ratio}")
    if diffs:
        print("\nsame start (MLS), 20 iterations each, energies by puppet.arap_energy:")
        print(f"{'mesh':34s} {'max |U_p - U_igl|':>18s} {'E puppet':>14s} {'E libigl':>14s} {'dE':>10s}")
        for label, dmax, ep, ei in diffs:
            print(f"{label:34s} {dmax:18.3e} {ep:14.6f} {ei:14.6f} {ep - ei:10.2e}")
    print("\nfree-block factorisation (both coordinates per solve):")
    print(f"{'mesh':34s} {'factoriser':10s} {'factor ms':>10s} {'solve ms':>9s}")
    for label, kind, tf, ts in facs:
        print(f"{label:34s} {kind:10s} {1e3 * tf:10.2f} {1e3 * ts:9.3f}")
    print(f"\nfactorisations done by puppet.deform.arap in this run: {arap_mod.FACTORIZATIONS}")


if __name__ == "__main__":
    main()
