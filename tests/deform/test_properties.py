"""Property tests of the deformers on random meshes, pins and targets (hypothesis).

Meshes: jittered, stretched grids (fixed connectivity: obtuse and near-degenerate
triangles) and quality-triangulated random star-shaped polygons, at scales from 1e-2 to
1e3 px. Pins: one to five vertices. Targets: near their rest places, anywhere up to 1e6
px, coincident with another pin's target, or a micrometre from it.
Every deformer must give finite vertices with the pins exactly on their targets; the
relaxation must stay within its work budget and never add folds.

The profile is derandomised and small so the suite stays fast; a longer sweep:
``PUPPET_SWEEP=2000 .venv/bin/python -m pytest -q tests/deform/test_properties.py``.
"""
from __future__ import annotations

import os

import numpy as np
import pytest
import triangle
pytest.importorskip("hypothesis", reason="hypothesis (a test extra: pip install -e '.[test]') is not installed")
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from puppet.deform import (arap_precompute, arap_solve, arap_solve_rotated, folded_triangles,
                           igarashi_precompute, igarashi_solve, mls_object_space,
                           relax_foldovers, skeleton_precompute, skeleton_solve)

SWEEP = int(os.environ.get("PUPPET_SWEEP", "0"))
settings.register_profile("deform", derandomize=True, deadline=None, print_blob=True,
                          database=None, max_examples=SWEEP or 25,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
PROFILE = settings.get_profile("deform")


def grid(nx, ny, jitter, stretch, seed):
    """A jittered grid, each quad split along a random diagonal."""
    rng = np.random.default_rng(seed)
    X, Y = np.meshgrid(np.arange(nx, dtype=float), np.arange(ny, dtype=float))
    V = np.c_[X.ravel(), Y.ravel()] + rng.uniform(-jitter, jitter, (nx * ny, 2))
    V *= [stretch, 1.0]
    i = (np.arange(ny - 1)[:, None] * nx + np.arange(nx - 1)[None]).ravel()
    a, b, c, d = i, i + 1, i + nx + 1, i + nx
    flip = rng.random(len(i)) < 0.5
    F = np.r_[np.where(flip[:, None], np.c_[a, b, c], np.c_[a, b, d]),
              np.where(flip[:, None], np.c_[a, c, d], np.c_[b, c, d])]
    return V, F.astype(np.int64)


def polygon(k, seed, quality):
    """A random star-shaped polygon, triangulated by Triangle."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    t = t[np.r_[True, np.diff(t) > 1e-3]]
    r = rng.uniform(0.3, 1.0, len(t)) * 10
    P = np.c_[r * np.cos(t), r * np.sin(t)]
    seg = np.c_[np.arange(len(P)), (np.arange(len(P)) + 1) % len(P)]
    T = triangle.triangulate({"vertices": P, "segments": seg}, ("pq25a1.5Q" if quality else "pQ"))
    return T["vertices"], T["triangles"].astype(np.int64)


@st.composite
def meshes(draw):
    seed = draw(st.integers(0, 2**31))
    if draw(st.booleans()):
        V, F = grid(draw(st.integers(3, 9)), draw(st.integers(3, 9)),
                    draw(st.sampled_from([0.0, 0.2, 0.3])), draw(st.sampled_from([1.0, 3.0, 0.2])), seed)
    else:
        V, F = polygon(draw(st.integers(3, 24)), seed, draw(st.booleans()))
    scale = draw(st.sampled_from([0.01, 1.0, 30.0, 1000.0]))
    offset = draw(st.sampled_from([0.0, 500.0, -1e5]))
    return V * scale + offset, F


@st.composite
def poses(draw):
    V, F = draw(meshes())
    n = len(V)
    k = draw(st.integers(1, min(5, n)))
    b = np.array(draw(st.lists(st.integers(0, n - 1), min_size=k, max_size=k, unique=True)))
    span = float(np.ptp(V, axis=0).max())
    bc = V[b].copy()
    for i in range(k):
        how = draw(st.sampled_from(["near", "far", "huge", "same", "micron"]))
        event(f"a target {how}")
        if how == "near":
            bc[i] += draw(st.tuples(*[st.floats(-1.0, 1.0)] * 2)) * np.array(span)
        elif how == "far":  # up to 5x the mesh size away
            bc[i] += np.array(draw(st.tuples(*[st.floats(-5.0, 5.0)] * 2))) * span
        elif how == "huge":
            bc[i] = draw(st.tuples(*[st.floats(-1e6, 1e6)] * 2))
        elif how == "same" and i:
            bc[i] = bc[draw(st.integers(0, i - 1))]
        elif how == "micron" and i:
            bc[i] = bc[draw(st.integers(0, i - 1))] + [1e-6, -1e-6]
    return V, F, b, bc


def check(U, b, bc):
    assert np.isfinite(U).all(), "non-finite vertices"
    assert np.abs(U[b] - bc).max() <= 1e-9, "pins off their targets"


@PROFILE
@given(poses(), st.sampled_from(["cotangent", "uniform", "cotangent-raw"]),
       st.sampled_from([None, None, 3.0, 30.0]))
def test_arap_and_relaxation(pose, weights, budget):
    V, F, b, bc = pose
    data = arap_precompute(V, F, b, weights=weights)
    U = arap_solve(data, bc)
    check(U, b, bc)
    info = {}
    R = relax_foldovers(data, U, bc, info=info, budget=budget)
    if budget is not None:  # a budget that binds: still the same shape every time
        assert np.array_equal(R, relax_foldovers(data, U, bc, budget=budget))
    check(R, b, bc)
    assert info["units"] <= info["budget"], "relaxation over its work budget"
    assert len(folded_triangles(V, R, F)) <= len(folded_triangles(V, U, F))
    event("plain ARAP folds" if info["folds_in"] else "no folds")
    if info["folds_in"]:
        event("relaxed: fold-free" if info["folds_out"] == 0 else "relaxed: folds left")
        event("relaxation used its whole budget" if info["budget"] - info["units"] < 1 else
              "relaxation ended within its budget")


@PROFILE
@given(poses(), st.data())
def test_rotated_pins(pose, data):
    V, F, b, bc = pose
    angles = np.array(data.draw(st.lists(st.sampled_from([0.0, 30.0, -90.0, 180.0, 1e-9]),
                                         min_size=len(b), max_size=len(b))))
    U = arap_solve_rotated(arap_precompute(V, F, b), bc, angles)
    check(U, b, bc)


@PROFILE
@given(poses())
def test_igarashi_mls_and_skeleton(pose):
    V, F, b, bc = pose
    check(igarashi_solve(igarashi_precompute(V, F, b), bc), b, bc)
    data = arap_precompute(V, F, b)
    check(mls_object_space(V, data.D, bc, V[b], kind="rigid"), b, bc)
    bones = np.c_[np.arange(len(b) - 1), np.arange(1, len(b))]
    if len(b) > 1 and len(np.unique(V[b], axis=0)) == len(b):
        check(skeleton_solve(skeleton_precompute(V, F, b, bones), bc), b, bc)


def test_named_extremes():
    """The issue's cases: a far drag, coincident targets, a micrometre apart, 1e6 px."""
    V, F = polygon(16, 3, True)
    V *= 20
    b = np.array([0, 5, 9])
    data = arap_precompute(V, F, b)
    for bc in (V[b] + [[0, 0], [4000, 0], [0, -4000]],
               np.array([V[b[0]], V[b[0]], V[b[2]]]),
               np.array([V[b[0]], V[b[0]] + 1e-6, V[b[2]]]),
               np.array([[1e6, 1e6], [-1e6, 1e6], [0, -1e6]])):
        U = arap_solve(data, bc)
        check(U, b, bc)
        info = {}
        R = relax_foldovers(data, U, bc, info=info)
        check(R, b, bc)
        assert info["units"] <= info["budget"]
