"""Shared by the benchmark scripts: test meshes, pins, timing."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import triangle

from benchmarks.bench_import import make_psd


def disc(n_boundary: int, max_area: float, radius: float = 100.0):
    """A quality-triangulated disc: V (n, 2), F (m, 3)."""
    t = np.linspace(0, 2 * np.pi, n_boundary, endpoint=False)
    pts = radius * np.c_[np.cos(t), np.sin(t)]
    seg = np.c_[np.arange(n_boundary), (np.arange(n_boundary) + 1) % n_boundary]
    T = triangle.triangulate({"vertices": pts, "segments": seg}, f"pq30a{max_area}")
    return T["vertices"], T["triangles"].astype(np.int64)


def star(spikes: int = 5, r_in: float = 35.0, r_out: float = 100.0, step: float = 4.0,
         max_area: float = 1.6):
    """A star polygon (boundary split every ``step``), quality-triangulated without
    Steiner points on the boundary: obtuse triangles along it give negative cotangent
    weights (156 edges at the defaults, 4.9k vertices). V (n, 2), F (m, 3)."""
    k = 2 * spikes
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    r = np.where(np.arange(k) % 2 == 0, r_out, r_in)
    corners = np.c_[r * np.cos(t), r * np.sin(t)]
    pts = []
    for i in range(k):
        a, b = corners[i], corners[(i + 1) % k]
        m = int(np.ceil(np.linalg.norm(b - a) / step))
        pts += [a + (b - a) * s for s in np.arange(m) / m]
    pts = np.array(pts)
    seg = np.c_[np.arange(len(pts)), (np.arange(len(pts)) + 1) % len(pts)]
    T = triangle.triangulate({"vertices": pts, "segments": seg}, f"pq30Ya{max_area}Q")
    return T["vertices"], T["triangles"].astype(np.int64)


def pins_and_targets(V):
    """Five pins spread over a radius-100 disc and a pose for them."""
    spots = np.array([[0, 0], [70, 0], [-70, 0], [0, 70], [0, -70]], float)
    b = np.array([np.argmin(np.linalg.norm(V - s, axis=1)) for s in spots])
    bc = V[b] + np.array([[0, 0], [25, -30], [-10, 15], [20, 10], [-15, -5]], float)
    return b, bc


def best(fn, repeat=5, warmup=True):
    """Best wall time of `repeat` calls (after one warm-up call), in seconds; last result."""
    out = fn() if warmup else None
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def psd4k_scene(folder: str) -> str:
    """The 20-part 4000x4000 PSD scene of issue 31, made once per ``folder`` and reused:
    ``bench_import.make_psd(art.psd, 4000, 20)``, then ``puppet init art.psd -o s.json
    --pins auto --links auto`` in a new process. Returns the scene's path."""
    os.makedirs(folder, exist_ok=True)
    art, path = os.path.join(folder, "art.psd"), os.path.join(folder, "s.json")
    if not os.path.exists(path):
        if not os.path.exists(art):
            make_psd(art + ".part", 4000, 20)
            os.replace(art + ".part", art)
        subprocess.run([sys.executable, "-m", "puppet", "init", art, "-o", path, "--pins", "auto", "--links", "auto"],
                       check=True, capture_output=True, timeout=900, cwd=folder)
    return path


def middle_pin(path: str) -> tuple[str, np.ndarray]:
    """The interior pin of the scene file ``path`` nearest the centroid of its interior
    pins (the pin a scale benchmark drags), and where it is (2,)."""
    with open(path) as f:
        pins = [p for p in json.load(f)["pins"] if p.get("kind", "interior") == "interior"]
    at = np.array([p["at"] for p in pins], float)
    k = int(np.argmin(np.linalg.norm(at - at.mean(axis=0), axis=1)))
    return pins[k]["name"], at[k]


def at_rest(preview, exact) -> np.ndarray:
    """The deformation of a preview layer read at the exact layer's rest vertices: (n, 2)
    (both :class:`~puppet.scene.rig.core.LayerResult`). The same rest mesh gives the
    preview's own vertices; another (a proxy, a subspace's mesh) is read through its
    triangles: each rest vertex is placed in the triangle, of the 8 with the nearest
    centroids, where its smallest barycentric coordinate is largest (clamped to >= 0,
    so a vertex outside the preview's outline takes the nearest edge's deformation)."""
    from scipy.spatial import cKDTree

    if preview.rest.shape == exact.rest.shape and np.array_equal(preview.rest, exact.rest):
        return preview.deformed
    F, V, U = preview.triangles, preview.rest, preview.deformed
    _, cand = cKDTree(V[F].mean(axis=1)).query(exact.rest, k=min(8, len(F)))
    cand = cand.reshape(len(exact.rest), -1)
    a, b, c = (V[F[cand, i]] for i in range(3))  # (n, k, 2)
    e1, e2, q = b - a, c - a, exact.rest[:, None, :] - a
    det = e1[..., 0] * e2[..., 1] - e2[..., 0] * e1[..., 1]
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    l1 = (q[..., 0] * e2[..., 1] - e2[..., 0] * q[..., 1]) / det
    l2 = (e1[..., 0] * q[..., 1] - q[..., 0] * e1[..., 1]) / det
    lam = np.stack([1 - l1 - l2, l1, l2], axis=-1)
    rows = np.arange(len(cand))
    best = np.argmax(lam.min(axis=-1), axis=1)
    w = np.clip(lam[rows, best], 0, None)
    w /= w.sum(axis=1, keepdims=True)
    return np.einsum("nk,nkd->nd", w, U[F[cand[rows, best]]])


def pose_gap(preview: list, exact: list, pin: str) -> np.ndarray:
    """Distances (px) between a preview's layers and the exact ones, over the vertices of
    the exact group that holds ``pin`` that the drag moves (> 0.01 px from rest in the
    exact pose or in the preview: an island without pins, left at rest, does not count)."""
    group = next(r.group for r in exact if pin in r.pins)
    shown = {r.name: r for r in preview}
    gaps = []
    for r in exact:
        if r.group == group:
            seen = at_rest(shown[r.name], r)
            moved = np.maximum(np.linalg.norm(r.deformed - r.rest, axis=1), np.linalg.norm(seen - r.rest, axis=1))
            gaps.append(np.linalg.norm(seen - r.deformed, axis=1)[moved > 0.01])
    return np.concatenate(gaps)
