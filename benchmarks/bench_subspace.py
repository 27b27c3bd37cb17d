"""The two reduced models issue 31 asked to compare for drag previews, side by side on the
same drags: the coarse proxy puppet uses (``puppet.scene.rig.reduced``) and a skinning
subspace in the manner of Fast Automatic Skinning Transformations (Jacobson et al. 2012),
written here only to measure it.

The subspace: handles at the group's pins plus ``--handles`` more vertices by farthest-point
sampling; biharmonic weights over the group's mesh (the ARAP Laplacian ``L`` and lumped
areas ``M``: minimise ``w' L M^-1 L w`` with each handle's weight 1 at itself and 0 at the
other handles); linear blend skinning with an affine map per handle (``U = M_lbs T``, T of
3 x 2 per handle); rotation clusters by k-means over the weight rows; local/global ARAP in
the subspace with the pins as hard constraints (the global step is one precomputed KKT
solve of 3h + k unknowns). It starts from rest (the identity maps) every frame and runs
``--iterations`` local/global steps, so it is a function of the pins, as the proxy is.

For each of ``--drags`` random ordinary drags (the rule of tests/scene/drag/test_reduced.py)
it prints the 95th percentile and largest distance (px) of the fine vertices between each
model's preview and the exact release, and the CPU time per frame of each model's solve
(the proxy: ``reduced_solve``; the subspace: its iterations plus the coarse meshes' vertices
``U = Mc T``). Then one table: the medians and worst cases, the precomputation times and the
load average.

Usage: python benchmarks/bench_subspace.py SCENE.json [--handles 60] [--clusters 200]
       [--iterations 40] [--drags 10] [--seed 1]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
import scipy.sparse as sp

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import puppet  # noqa: E402
from puppet.deform.factor import factorize  # noqa: E402
from puppet.scene.rig import reduced as R  # noqa: E402
from tests.scene.drag.test_reduced import ordinary, surface_error  # noqa: E402


# -- the subspace ----------------------------------------------------------------------------------
def handles(V: np.ndarray, pins: np.ndarray, extra: int) -> np.ndarray:
    """The pins plus ``extra`` vertices, each the farthest (Euclidean) from those chosen."""
    chosen = list(pins)
    d = np.min(np.linalg.norm(V[:, None, :] - V[pins][None], axis=2), axis=1)
    for _ in range(extra):
        j = int(np.argmax(d))
        chosen.append(j)
        d = np.minimum(d, np.linalg.norm(V - V[j], axis=1))
    return np.array(chosen)


def lumped_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    T = V[F]
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    a = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / 2
    return np.maximum(np.bincount(F.ravel(), np.repeat(a / 3, 3), len(V)), 1e-12)


def biharmonic(L: sp.csr_matrix, area: np.ndarray, H: np.ndarray) -> np.ndarray:
    """(n, h) weights: 1 at their own handle, 0 at the others, biharmonic elsewhere."""
    n = L.shape[0]
    Q = (L @ sp.diags(1.0 / area) @ L).tocsr()
    free = np.setdiff1d(np.arange(n), H)
    fac = factorize(Q[free][:, free].tocsc(), "qdldl")
    rhs = -(Q[free][:, H]).toarray()
    W = np.zeros((n, len(H)))
    W[H, np.arange(len(H))] = 1.0
    W[free] = np.stack([fac.solve(rhs[:, j]) for j in range(len(H))], axis=1)
    return W


def kmeans(X: np.ndarray, k: int, seed: int, rounds: int = 12) -> np.ndarray:
    """Labels of the rows of ``X`` in ``k`` clusters (Lloyd's iterations)."""
    rng = np.random.default_rng(seed)
    C = X[rng.choice(len(X), k, replace=False)]
    for _ in range(rounds):
        d = (X * X).sum(1)[:, None] - 2 * X @ C.T + (C * C).sum(1)[None]
        lab = np.argmin(d, axis=1)
        for c in range(k):
            members = X[lab == c]
            if len(members):
                C[c] = members.mean(axis=0)
    return lab


class Subspace:
    """Skinning subspace ARAP of one group (``data``: its fine ArapData)."""

    def __init__(self, data, extra: int, clusters: int, seed: int):
        V, b = data.V, data.b
        self.H = handles(V, b, extra)
        self.W = biharmonic(data.L, lumped_areas(V, data.F), self.H)
        self.M = lbs(self.W, V)
        h3 = self.M.shape[1]
        lab = kmeans(self.W, clusters, seed)
        n, e = len(V), len(data.ei)
        # D (2e, n): directed edge differences; Z (2e, 2c): w_e ev_e into its cell's cluster
        D = sp.csr_matrix((np.r_[np.ones(e), -np.ones(e)], (np.r_[np.arange(e), np.arange(e)],
                                                             np.r_[data.ei, data.ej])), shape=(e, n))
        c = lab[data.ei]
        Z = sp.csr_matrix((np.r_[data.ew * data.ev[:, 0], data.ew * data.ev[:, 1]],
                           (np.r_[np.arange(e), np.arange(e)], np.r_[2 * c, 2 * c + 1])), shape=(e, 2 * clusters))
        self.Hc = self.M.T @ (D.T @ Z).toarray()  # (3h, 2c): S_c = T' Hc[:, 2c:2c+2]
        A = self.M.T @ (D.T @ (data.ew[:, None] * (D @ self.M)))  # the energy's quadratic form
        C = self.M[b]  # pins are handles: u(pin) = M[pin] T
        k = len(b)
        K = np.block([[A, C.T], [C, np.zeros((k, k))]])
        Kinv = np.linalg.pinv(K)
        self.P1H = Kinv[:h3, :h3] @ self.Hc  # T = P1H Rs + P2 targets
        self.P2 = Kinv[:h3, h3:]
        self.clusters = clusters
        self.T0 = np.tile(np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]), (len(self.H), 1))
        self.T0 = self.T0.reshape(len(self.H), 3, 2).transpose(1, 0, 2).reshape(-1, 2)

    def solve(self, bc: np.ndarray, iterations: int) -> np.ndarray:
        """T (3h, 2) for pins at ``bc``."""
        T, fixed = self.T0, self.P2 @ bc
        c = self.clusters
        for _ in range(iterations):
            S = (T.T @ self.Hc).reshape(2, c, 2)  # S[:, c, :] = S_c
            th = np.arctan2(S[1, :, 0] - S[0, :, 1], S[0, :, 0] + S[1, :, 1])
            co, si = np.cos(th), np.sin(th)
            Rs = np.stack([np.stack([co, -si], 1), np.stack([si, co], 1)], 1)  # R_c' rows: (c, 2, 2)
            T = self.P1H @ Rs.reshape(-1, 2) + fixed
        return T


def lbs(W: np.ndarray, V: np.ndarray) -> np.ndarray:
    """(n, 3h) linear blend skinning matrix: U = lbs(W, V) @ T, T = [Tx; Ty; Tt] (3h, 2)."""
    return np.hstack([W * V[:, :1], W * V[:, 1:], W])


# -- the comparison --------------------------------------------------------------------------------
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--handles", type=int, default=60)
    ap.add_argument("--clusters", type=int, default=200)
    ap.add_argument("--iterations", type=int, default=40)
    ap.add_argument("--drags", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    doc = puppet.load_scene(a.scene)
    built = doc.built
    gi = max(range(len(built.groups)), key=lambda i: len(built.groups[i].mesh.V))
    g, data = built.groups[gi], built.pre[gi].arap
    t = time.process_time()
    red = R.reduced_for(doc.rig, built, gi) or R.build_reduced(built, gi, R.REDUCED_VERTICES)
    t_proxy = time.process_time() - t
    t = time.process_time()
    sub = Subspace(data, a.handles, a.clusters, a.seed)
    t_sub = time.process_time() - t
    Mc = red.C @ sub.M  # the coarse meshes' vertices in the subspace (drawn like the proxy's)
    print(f"group: {len(g.mesh.V)} vertices, {len(data.b)} pins; proxy {len(red.group.mesh.V)} vertices "
          f"(built in {t_proxy:.2f} s CPU); subspace {len(sub.H)} handles, {a.clusters} clusters "
          f"(built in {t_sub:.2f} s CPU)", flush=True)
    rng = np.random.default_rng(a.seed)
    names = [p.name for p in doc.data.pins if p.kind == "interior"]
    order = [p.name for p in doc.data.pins]
    rows = []
    while len(rows) < a.drags:
        name = str(rng.choice(names))
        i = order.index(name)
        start = np.asarray(doc.state().to[i])
        ang, dist = rng.uniform(0, 2 * np.pi), rng.uniform(20, 200)
        goal = start + dist * np.array([np.cos(ang), np.sin(ang)])
        if not ordinary(doc, i, goal, None):
            continue
        d = doc.drag(name)
        proxy = d.move_layers(goal)
        state = d._state
        d.cancel()
        pose = built.group_pose(gi, state)
        t = time.process_time()
        for _ in range(3):
            R.reduced_solve(red, built.data.deformer, pose)
        cpu_proxy = (time.process_time() - t) / 3
        t = time.process_time()
        for _ in range(3):
            T = sub.solve(pose.bc, a.iterations)
            Mc @ T
        cpu_sub = (time.process_time() - t) / 3
        d = doc.drag(name)
        d.move_layers(goal)
        exact = d.release_layers()
        doc.undo()
        e_proxy = surface_error(proxy, exact, {gi})
        U = sub.M @ T
        by_name = {x.name: x.deformed for x in exact}
        shown = np.concatenate([U[g.mesh.maps[li]] for li in range(len(g.layers))])
        truth = np.concatenate([by_name[built.data.layers[k].name] for k in g.layers])
        e_sub = np.linalg.norm(shown - truth, axis=1)
        rows.append((dist, e_proxy, e_sub, cpu_proxy, cpu_sub))
        print(f"drag {dist:5.0f} px | proxy p95 {np.percentile(e_proxy, 95):6.2f} max {e_proxy.max():6.2f} "
              f"{1000 * cpu_proxy:5.1f} ms | subspace p95 {np.percentile(e_sub, 95):6.2f} max {e_sub.max():6.2f} "
              f"{1000 * cpu_sub:5.1f} ms", flush=True)
    print(f"\nload {os.getloadavg()[0]:.1f}\n")
    print("| Model | Vertices or handles | Build, s CPU | Solve, ms CPU (median) | p95 px: median / worst | max px: worst |")
    print("|---|---|---|---|---|---|")
    for label, size, built_s, col in (("coarse proxy", len(red.group.mesh.V), t_proxy, 1),
                                      ("subspace", len(sub.H), t_sub, 2)):
        p95 = [np.percentile(r[col], 95) for r in rows]
        print(f"| {label} | {size} | {built_s:.2f} | {1000 * np.median([r[col + 2] for r in rows]):.1f} | "
              f"{np.median(p95):.2f} / {max(p95):.2f} | {max(r[col].max() for r in rows):.2f} |")
    return 0


if __name__ == "__main__":
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):  # as puppet's solves run (one BLAS thread); spinning BLAS threads skew CPU time
        sys.exit(main())
