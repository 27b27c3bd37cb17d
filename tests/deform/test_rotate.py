import numpy as np
import pytest

import puppet.deform.arap as arap_mod
import puppet.deform.factor as factor_mod
from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.rotate import (
    arap_solve_rotated,
    cell_residuals,
    held_rotations,
    rotation_initial_guess,
    screen_rotation,
)
from tests.deform.meshes import triangulate



def puppet_shape(max_area=1.0):
    """Body bar [0,40]x[20,30], neck [26,32]x[14,20], head block [20,38]x[0,14] (y down)."""
    return triangulate([[0, 20], [26, 20], [26, 14], [20, 14], [20, 0], [38, 0], [38, 14],
                        [32, 14], [32, 20], [40, 20], [40, 30], [0, 30]], max_area)


def nearest(V, pts):
    return np.array([np.argmin(np.linalg.norm(V - p, axis=1)) for p in pts])


def screen_angle(V0, U, mask):
    """Best rotation (Procrustes) from V0[mask] to U[mask], in on-screen CCW degrees."""
    X = V0[mask] - V0[mask].mean(0)
    Y = U[mask] - U[mask].mean(0)
    raw = np.arctan2((X[:, 0] * Y[:, 1] - X[:, 1] * Y[:, 0]).sum(), (X * Y).sum())
    return -np.degrees(raw)  # y points down: on screen CCW is clockwise in raw (x, y)


V, F = puppet_shape()
HIP, CHEST, HEAD = 0, 1, 2
B = nearest(V, [[3, 25], [20, 25], [29, 9]])  # hip, chest, a pin inside the head block
DATA = arap_precompute(V, F, B)
BC = V[B] + np.array([[-2.0, 3.0], [1.0, -1.0], [2.0, 1.0]])


def head_angles(theta):
    a = np.zeros(len(B))
    a[HEAD] = theta
    return a


def test_screen_rotation_is_counter_clockwise_on_screen():
    # 90 degrees CCW on screen (y down): right -> up (smaller y), up -> left
    R = screen_rotation([90.0])[0]
    np.testing.assert_allclose(R @ [1.0, 0.0], [0.0, -1.0], atol=1e-15)
    np.testing.assert_allclose(R @ [0.0, -1.0], [-1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(screen_rotation([0.0])[0], np.eye(2))


def test_rest_pose_with_zero_angles_gives_rest_mesh():
    U = arap_solve_rotated(DATA, V[B], np.zeros(len(B)))
    assert np.abs(U - V).max() < 1e-9


def test_all_angles_zero_is_exactly_arap_solve_and_factorises_nothing():
    before = factor_mod.FACTORIZATIONS
    info = {}
    U = arap_solve_rotated(DATA, BC, np.zeros(len(B)), iterations=15, info=info)
    assert factor_mod.FACTORIZATIONS == before
    np.testing.assert_array_equal(U, arap_solve(DATA, BC, iterations=15))
    assert info["rounds"] == [] and info["held"] == 0


def test_initial_guess_turns_each_vertex_about_its_nearest_pin():
    ang = head_angles(30.0)
    U0 = rotation_initial_guess(DATA, BC, ang)
    near = DATA.D.argmin(axis=0)
    c, s = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
    R = np.array([[c, s], [-s, c]])  # 30 degrees counter-clockwise on screen (y down)
    t = near == HEAD
    np.testing.assert_allclose(U0[t], BC[HEAD] + (V[t] - V[B[HEAD]]) @ R.T, atol=1e-12)
    # vertices of pins without an angle keep the ordinary MLS guess of arap_solve
    mls = arap_solve(DATA, BC, iterations=0)
    np.testing.assert_array_equal(U0[~t], mls[~t])
    np.testing.assert_array_equal(rotation_initial_guess(DATA, BC, np.zeros(len(B))), mls)
    np.testing.assert_array_equal(U0[B], BC)


@pytest.mark.parametrize("theta", [-30.0, 20.0, 45.0])
def test_region_around_pin_turns_by_its_angle(theta):
    U = arap_solve_rotated(DATA, BC, head_angles(theta))
    p = V[B[HEAD]]
    disc = np.linalg.norm(V - p, axis=1) < 4.0
    assert disc.sum() > 20
    assert abs(screen_angle(V, U, disc) - theta) <= 6.0
    # explicit screen expectation, written out (not via screen_rotation): with y down,
    # counter-clockwise on screen takes (1, 0) to (cos, -sin), so a point right of
    # the pin ends up above it (smaller y) for theta > 0
    q = nearest(V, [p + [4.0, 0.0]])[0]
    assert np.sign(U[q, 1] - U[B[HEAD], 1]) == -np.sign(theta)
    r = V[disc] - p
    c, s = np.cos(np.radians(theta)), np.sin(np.radians(theta))
    expected = np.c_[c * r[:, 0] + s * r[:, 1], -s * r[:, 0] + c * r[:, 1]]
    d = U[disc] - U[B[HEAD]]
    # best angle, about the pin, between the expected and the obtained spokes
    off = np.arctan2((expected[:, 0] * d[:, 1] - expected[:, 1] * d[:, 0]).sum(),
                     (expected * d).sum())
    assert abs(np.degrees(off)) <= 6.0


def test_pins_exactly_at_targets():
    ang = np.array([10.0, -15.0, 40.0])
    for rounds in (0, 3):
        U = arap_solve_rotated(DATA, BC, ang, rounds=rounds)
        np.testing.assert_array_equal(U[B], BC)


@pytest.mark.parametrize("theta", [-30.0, 45.0])
def test_far_from_the_turned_pin_barely_changes(theta):
    U0 = arap_solve(DATA, BC)
    U = arap_solve_rotated(DATA, BC, head_angles(theta))
    change = np.linalg.norm(U - U0, axis=1)
    far = V[:, 0] < 10.0  # left end of the body, ~35 px along the shape from the head pin
    head = V[:, 1] < 14.0
    assert change[head].max() > 4.0
    assert change[far].max() < 0.1 * change[head].max()
    assert change[far].max() < 0.5


@pytest.mark.parametrize("theta", [-30.0, 20.0, 70.0])
def test_rigid_rotation_of_all_pins_with_equal_angles_rotates_mesh(theta):
    R = screen_rotation([theta])[0]
    c, t = np.array([15.0, 12.0]), np.array([4.0, -7.0])
    rigid = (V - c) @ R.T + c + t
    U = arap_solve_rotated(DATA, rigid[B], np.full(len(B), theta))
    assert np.abs(U - rigid).max() < 1e-9


def test_lone_pin_with_angle_turns_whole_layer_about_it():
    Vs, Fs = triangulate([[0, 0], [10, 0], [10, 4], [0, 4]], 1.0)
    b = nearest(Vs, [[2, 2]])
    data = arap_precompute(Vs, Fs, b)
    U = arap_solve_rotated(data, Vs[b], [90.0])
    # 90 degrees CCW on screen about the pin: the bar that pointed right points up
    expected = Vs[b[0]] + (Vs - Vs[b[0]]) @ np.array([[0.0, 1.0], [-1.0, 0.0]]).T
    assert np.abs(U - expected).max() < 1e-9
    right_end = np.argmax(Vs[:, 0])
    assert U[right_end, 1] < Vs[b[0], 1] - 7.0


def test_held_rotations_reach_half_way_to_the_nearest_other_pin():
    cells, cm1, s = held_rotations(DATA, head_angles(20.0))
    d_other = DATA.D[HEAD, B[[HIP, CHEST]]].min()
    assert B[HEAD] in cells
    assert (DATA.D[HEAD, cells] <= 0.5 * d_other).all()
    assert (DATA.D.argmin(axis=0)[cells] == HEAD).all()
    phi = np.radians(-20.0)  # raw-coordinate angle of +20 degrees on screen
    np.testing.assert_allclose(cm1, np.cos(phi) - 1.0, atol=1e-15)
    np.testing.assert_allclose(s, np.sin(phi), atol=1e-15)
    assert len(held_rotations(DATA, np.zeros(len(B)))[0]) == 0


def test_residual_rounds_are_local_and_never_raise_the_energy():
    ang = head_angles(-30.0)
    held = held_rotations(DATA, ang)
    info = {}
    U3 = arap_solve_rotated(DATA, BC, ang, rounds=3, info=info)
    U0 = arap_solve_rotated(DATA, BC, ang, rounds=0)
    E3, E0 = cell_residuals(DATA, U3, held).sum(), cell_residuals(DATA, U0, held).sum()
    assert E3 <= E0 * (1 + 1e-12)
    assert info["rounds"] and info["held"] > 0
    assert all(0 < r["free"] < 0.5 * len(DATA.free) for r in info["rounds"])
    # nothing above eps: no round, no factorisation
    before = factor_mod.FACTORIZATIONS
    info = {}
    U = arap_solve_rotated(DATA, BC, ang, eps=np.inf, info=info)
    assert factor_mod.FACTORIZATIONS == before and info["rounds"] == []
    np.testing.assert_array_equal(U, U0)


def test_cell_residuals_sum_to_arap_energy():
    U = arap_solve(DATA, BC, iterations=3)
    r = cell_residuals(DATA, U)
    assert r.shape == (len(V),)
    assert np.isclose(r.sum(), arap_mod.arap_energy(DATA, U), rtol=1e-12)
    assert np.abs(cell_residuals(DATA, V)).max() < 1e-20


def test_bad_angles_raise():
    with pytest.raises(ValueError, match="angles_deg"):
        arap_solve_rotated(DATA, BC, [1.0, 2.0])
    with pytest.raises(ValueError, match="finite"):
        arap_solve_rotated(DATA, BC, [0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="bc"):
        arap_solve_rotated(DATA, BC[:2], np.zeros(3))
