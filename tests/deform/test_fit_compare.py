"""The measures of ``benchmarks/fit_compare.py`` (the docs/fit comparison) on hand-checked
cases: distortion of a triangle pair, the outline gap, the target maps, the check pattern.
The script is loaded from its file (the benchmarks folder is not a package of puppet)."""
from __future__ import annotations

import importlib.util
import os
import sys

import numpy as np
import pytest

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks", "fit_compare.py")


@pytest.fixture(scope="module")
def fc():
    spec = importlib.util.spec_from_file_location("_fit_compare_script", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up there
    try:
        spec.loader.exec_module(mod)
        yield mod
    finally:
        del sys.modules[spec.name]


# a unit square as two triangles, and its boundary
V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
F = np.array([[0, 1, 2], [0, 2, 3]])


def test_distortion_of_hand_checked_maps(fc):
    d = fc.distortion(V, F, V * [2.0, 1.0])  # a stretch by 2 along x: anisotropy 2, area 2
    assert d["aniso_mean"] == pytest.approx(2.0) and d["aniso_max"] == pytest.approx(2.0)
    assert (d["area_min"], d["area_max"], d["flipped"]) == (pytest.approx(2.0), pytest.approx(2.0), 0)
    c, s = np.cos(0.3), np.sin(0.3)
    d = fc.distortion(V, F, 1.5 * V @ np.array([[c, s], [-s, c]]) + 7.0)  # a similarity keeps angles
    assert d["aniso_max"] == pytest.approx(1.0) and d["area_min"] == pytest.approx(2.25)
    U = V.copy()
    U[3] = [2.0, 0.5]  # vertex 3 pulled through the diagonal: the second triangle folds
    d = fc.distortion(V, F, U)
    assert d["flipped"] == 1 and d["area_min"] < 0 < d["area_max"]
    assert d["aniso_mean"] == pytest.approx(1.0)  # only the triangle that did not fold counts


def test_outline_gap_is_the_symmetric_distance_of_the_outlines(fc):
    E = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    assert fc.outline_gap(E, V, V)[0] == 0.0
    gap, worst = fc.outline_gap(E, V, V * [1.5, 1.0])  # the right side 0.5 further out
    assert gap == pytest.approx(0.5)
    assert worst == 1  # the midpoint of the moved side, edge 1 -> 2, is the farthest
    # a shape inside another: the distance from the larger's corners counts too
    assert fc.outline_gap(E, V, (V - 0.5) * 3.0 + 0.5)[0] == pytest.approx(np.sqrt(2.0))


def test_target_maps(fc):
    P = np.array([[250.0, 100.0], [350.0, 300.0], [150.0, 20.0]])
    assert np.allclose(fc.narrower(250.0)(P), [[250, 100], [325, 300], [175, 20]])
    M = fc.mannequin(250.0, 20.0, 500.0)(P)
    assert np.allclose(M[2], [250 - 1.2 * 100, 20])  # 1.2 times as wide at the top, top fixed
    assert np.allclose(fc.mannequin(250.0, 20.0, 500.0)(np.array([[350.0, 500.0]])), [[350, 20 + 0.88 * 480]])
    T = fc.flare(250.0, 189.0, 470.0, 210.0)
    assert np.array_equal(T(P[:1]), P[:1])  # above the waist: unchanged
    assert np.allclose(T(np.array([[460.0, 470.0]])), [[460 + 210 * 0.3, 470 - 30]])
    R = fc.raise_sleeve((400.0, 140.0), (330.0, 55.0), (385.0, 205.0))
    torso, tip = np.array([[250.0, 300.0]]), np.array([[480.0, 160.0]])
    assert np.array_equal(R(torso), torso)  # left of the seam: unchanged
    d0, d1 = tip[0] - [400, 140], R(tip)[0] - [400, 140]
    assert np.hypot(*d1) == pytest.approx(np.hypot(*d0))  # turned about the pivot ...
    turn = np.degrees(np.arctan2(d1[1], d1[0]) - np.arctan2(d0[1], d0[0]))
    assert turn == pytest.approx(-30.0)  # ... by 30 degrees, up on screen


def test_check_pattern_keeps_the_alpha(fc):
    rgba = np.zeros((70, 70, 4), np.uint8)
    rgba[10:60, 10:60] = (200, 100, 50, 180)
    out = fc.check_pattern(rgba)
    assert np.array_equal(out[..., 3], rgba[..., 3])
    assert fc.CELL == 32
    assert np.array_equal(out[45, 45, :3], rgba[45, 45, :3])  # cell (1, 1) is light: colour kept
    assert np.array_equal(out[20, 40, :3], np.round(rgba[20, 40, :3] * 0.72).astype(np.uint8))  # cell (1, 0): dark
    assert np.array_equal(out[45, 32, :3], np.round(rgba[45, 32, :3] * 0.25).astype(np.uint8))  # a grid line
    assert np.array_equal(out[5, 5], rgba[5, 5])  # transparent pixels stay as they were
