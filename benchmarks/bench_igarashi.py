"""Igarashi two-step ARAP timings next to puppet's iterative ARAP (20 iterations).

Run:  python benchmarks/bench_igarashi.py
Needs `triangle`. Both solvers get the same disc mesh (about 5k and 20k vertices), the
same 5 pins and the same targets. "solve" is one pose from scratch: for Igarashi the
two back-substitutions (no factorisation), for ARAP the MLS initial guess plus 20
local/global iterations. The last columns score both results with puppet's
Sorkine-Alexa energy (`arap_energy`, cotangent weights), for context only.
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from benchmarks.common import best, disc, pins_and_targets  # noqa: E402

import puppet.deform.factor as factor_mod  # noqa: E402
from puppet.deform.arap import arap_energy, arap_precompute, arap_solve  # noqa: E402
from puppet.deform.igarashi import igarashi_precompute, igarashi_solve  # noqa: E402








def bench_mesh(V, F):
    b, bc = pins_and_targets(V)
    t_ipre, idata = best(lambda: igarashi_precompute(V, F, b))
    t_i1, _ = best(lambda: igarashi_solve(idata, bc, steps=1), repeat=5)
    t_i2, Ui = best(lambda: igarashi_solve(idata, bc), repeat=5)
    t_apre, adata = best(lambda: arap_precompute(V, F, b))
    t_a, Ua = best(lambda: arap_solve(adata, bc, iterations=20))
    return {"pre": (t_ipre, t_apre), "solve": (t_i2, t_a), "step1": t_i1,
            "E": (arap_energy(adata, Ui), arap_energy(adata, Ua)),
            "dU": np.abs(Ui - Ua).max(), "kind": idata.factor1.kind}


def main():
    meshes = [(240, 5.0), (480, 1.25)]
    rows = []
    for nb, area in meshes:
        V, F = disc(nb, area)
        rows.append((f"disc {len(V) / 1000:.0f}k ({len(V)} v, {len(F)} t)", bench_mesh(V, F)))
    print(f"Igarashi two-step (factoriser: {rows[0][1]['kind']}) vs puppet ARAP "
          "(MLS init + 20 iterations); ms, best of 3 (solves: best of 5)\n")
    head = (f"{'mesh':28s} {'method':16s} {'precompute':>10s} {'solve':>8s} "
            f"{'E_arap(U)':>10s}")
    print(head)
    print("-" * len(head))
    for label, r in rows:
        (tip, tap), (tis, tas), (ei, ea) = r["pre"], r["solve"], r["E"]
        print(f"{label:28s} {'igarashi':16s} {1e3 * tip:10.1f} {1e3 * tis:8.2f} {ei:10.2f}")
        print(f"{'':28s} {'igarashi step 1':16s} {'':>10s} {1e3 * r['step1']:8.2f} {'':>10s}")
        print(f"{'':28s} {'arap 20 it':16s} {1e3 * tap:10.1f} {1e3 * tas:8.2f} {ea:10.2f}")
        print(f"{'':28s} {'ratio arap/ig':16s} {tap / tip:10.2f} {tas / tis:8.2f}"
              f"   max|U_ig - U_arap| = {r['dU']:.2f} (disc radius 100)")
    print(f"\nfactorisations by puppet.deform.factor.factorize in this run: {factor_mod.FACTORIZATIONS}"
          f" (Igarashi: 2 per precompute, none per solve)")


if __name__ == "__main__":
    main()
