"""As-rigid-as-possible in-betweens (puppet.deform.interp) on hand-checked cases."""
import numpy as np
import pytest

from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.interp import (interp_pair, interp_precompute, interp_solve, jacobians, polar2,
                                  triangle_adjacency, unwrap_angles)
from tests.deform.meshes import nearest, rectangle, rot


def signed_area(U, F):
    a, b, c = U[F[:, 0]], U[F[:, 1]], U[F[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def test_jacobians_of_an_affine_map():
    V, F = rectangle(10, 4, 1.0)
    A = np.array([[1.5, 0.3], [-0.2, 0.8]])
    J = jacobians(V, F, V @ A.T + [7, -3])
    assert J.shape == (len(F), 2, 2) and np.allclose(J, A, atol=1e-12)


def test_polar2_hand_checked():
    th = np.radians(30)
    J = rot(th) @ np.diag([2.0, 0.5])
    theta, S = polar2(J[None])
    assert theta[0] == pytest.approx(th) and np.allclose(S[0], np.diag([2.0, 0.5]))
    # any matrix: R(theta) S gives it back and S is symmetric (also for a reflection)
    rng = np.random.default_rng(1)
    M = rng.normal(size=(50, 2, 2))
    theta, S = polar2(M)
    R = np.stack([rot(t) for t in theta])
    assert np.allclose(R @ S, M) and np.allclose(S, np.swapaxes(S, 1, 2))


def test_triangle_adjacency_of_two_triangles():
    F = np.array([[0, 1, 2], [2, 1, 3], [3, 4, 5]])
    assert triangle_adjacency(F).tolist() == [[0, 1]]


def test_unwrap_short_way_unless_nearly_half_a_turn():
    V, F = rectangle(40, 4, 0.5)
    x = V[F].mean(axis=1)[:, 0] / 40
    turns = 2 * np.pi * (np.arange(len(F)) % 3)  # whole turns in the input change nothing
    # up to 140 degrees everywhere: each triangle turns the short way
    true = np.radians(-60 + 200 * x)
    assert np.allclose(unwrap_angles(F, true + turns), true)
    # 0 .. 205 degrees along the strip: past 150 degrees either way round they follow
    # their neighbours (205 is not taken as the short -155)
    true = np.radians(205 * x)
    assert np.allclose(unwrap_angles(F, true + turns), true)
    # a turn of 180 degrees (+-1 degree noise): all one way round, not half and half
    noisy = np.pi + np.radians(np.random.default_rng(0).uniform(-1, 1, len(F)))
    got = unwrap_angles(F, noisy + turns)
    assert np.allclose(np.abs(got), np.abs(got[0]), atol=0.04) and abs(abs(got[0]) - np.pi) < 0.02
    # a strip wound 0 .. 270 degrees (a twisted joint): where it is past 150 degrees
    # it comes out at the short way round, -90, except where it is nearly half a turn
    true = np.radians(270 * x)
    got = np.degrees(unwrap_angles(F, true + turns))
    far = np.degrees(true) > 215
    assert np.allclose(got[far], np.degrees(true[far]) - 360)


def test_rotation_about_a_fixed_pin_is_exact():
    """Key B = key A turned 150 degrees about a pin that stays: every in-between is the
    shape turned by 150 u about it (linear vertex paths shrink it to 7 % of its area)."""
    V, F = rectangle(40, 6, 1.0)
    p = nearest(V, [[0, 3]])
    piv = V[p[0]]
    th = np.radians(150)
    UB = (V - piv) @ rot(th).T + piv
    data = interp_precompute(V, F, p)
    pair = interp_pair(data, V, UB)
    for u in (0.0, 0.25, 0.5, 0.9, 1.0):
        U = interp_solve(data, pair, u, anchors=p)
        assert np.allclose(U, (V - piv) @ rot(th * u).T + piv, atol=1e-8)
    line = 0.5 * V + 0.5 * UB
    ratio = signed_area(line, F) / signed_area(V, F)
    assert ratio.max() < 0.07  # (the straight-line in-between, for comparison)


def test_free_part_follows_its_least_moving_anchors():
    V, F = rectangle(20, 6, 1.0)
    UB = V + [10.0, -4.0]
    data = interp_precompute(V, F)  # nothing fixed: placed by the anchors
    b = nearest(V, [[0, 0], [20, 6]])
    pair = interp_pair(data, V, UB)
    assert np.allclose(interp_solve(data, pair, 0.3, anchors=b), V + [3.0, -1.2], atol=1e-9)


def test_key_meshes_exactly_at_the_ends_and_no_memory():
    V, F = rectangle(30, 6, 1.0)
    b = nearest(V, [[0, 0], [0, 6], [30, 3]])
    pre = arap_precompute(V, F, b)
    UA = arap_solve(pre, V[b] + [[0, 0], [0, 0], [-6, -12]])
    UB = arap_solve(pre, V[b] + [[0, 0], [0, 0], [-14, 20]])
    data = interp_precompute(V, F, b[:2])
    pair = interp_pair(data, UA, UB)
    assert np.allclose(interp_solve(data, pair, 0.0, anchors=b), UA, atol=1e-8)
    assert np.allclose(interp_solve(data, pair, 1.0, anchors=b), UB, atol=1e-8)
    mid = interp_solve(data, pair, 0.5, anchors=b)
    for u in (0.9, 0.1, 0.7):
        interp_solve(data, pair, u, anchors=b)
    again = interp_solve(interp_precompute(V, F, b[:2]), interp_pair(data, UA, UB), 0.5, anchors=b)
    assert np.array_equal(mid, again)  # a frame depends only on the keys and u
    assert np.allclose(mid[b[:2]], V[b[:2]])  # the still pins stay put


def test_multiple_parts_each_placed():
    V1, F1 = rectangle(10, 4, 1.0)
    V = np.vstack([V1, V1 + [30, 0]])
    F = np.vstack([F1, F1 + len(V1)])
    UB = V.copy()
    UB[len(V1):] += [0, 10]
    data = interp_precompute(V, F, [0])
    assert len(data.parts) == 1  # the second rectangle has no fixed vertex
    U = interp_solve(data, interp_pair(data, V, UB), 0.5)
    assert np.allclose(U[:len(V1)], V1) and np.allclose(U[len(V1):], V[len(V1):] + [0, 5])
