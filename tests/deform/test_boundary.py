import numpy as np
import pytest
from scipy.sparse import csgraph

from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.boundary import (
    boundary_edges,
    default_falloff,
    exterior_frame,
    exterior_positions,
    fine_deform,
)
from puppet.geom.contour import Region
from puppet.geom.geodesic import edge_graph
from puppet.geom.mesh import edges
from puppet.geom.triangulate import triangulate_regions


def rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def star(n_tips=5, r_out=120.0, r_in=60.0, centre=(200.0, 200.0)):
    ang = np.pi / 2 + np.arange(2 * n_tips) * np.pi / n_tips
    rad = np.where(np.arange(2 * n_tips) % 2 == 0, r_out, r_in)
    return np.c_[centre[0] + rad * np.cos(ang), centre[1] - rad * np.sin(ang)]


CENTRE = np.array([200.0, 200.0])


@pytest.fixture(scope="module")
def star_mesh():
    S = star()
    M = triangulate_regions([Region(S)], max_area=20.0, points=CENTRE[None])
    pin = np.flatnonzero(np.all(M.V == CENTRE, axis=1))
    assert len(pin) == 1
    return M.V, M.F, pin, S


def boundary_vertices(F):
    return np.unique(boundary_edges(F))


def depth_from_boundary(V, F):
    return csgraph.dijkstra(edge_graph(V, F), indices=boundary_vertices(F), min_only=True)


# --- frames ------------------------------------------------------------------------------

def test_frame_hand_checked_on_a_boundary_edge():
    V = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    F = np.array([[0, 1, 2]])
    fr = exterior_frame(V, [[1.0, -1.0], [2.0, 2.0]], F)
    # (1, -1): edge 0 -> 1, d = (2, 0), R90 d = (0, 2): (1, -1) = 0.5 d - 0.5 R90 d
    # (2, 2): closest to edge 1 -> 2 at (1, 1), d = (-2, 2), R90 d = (-2, -2)
    np.testing.assert_array_equal(fr.v1, [0, 1])
    np.testing.assert_array_equal(fr.v2, [1, 2])
    np.testing.assert_allclose(fr.s, [0.5, 0.5])
    np.testing.assert_allclose(fr.t, [-0.5, -0.5])
    np.testing.assert_allclose(exterior_positions(V, fr), [[1.0, -1.0], [2.0, 2.0]])


def test_frame_hand_checked_on_two_nearest_vertices():
    V = np.array([[0.0, 0.0], [4.0, 0.0], [10.0, 10.0], [0.0, 0.0]])  # vertex 3 repeats 0
    fr = exterior_frame(V, [[1.0, 1.0]])
    assert fr.v1[0] in (0, 3) and fr.v2[0] == 1  # the second one at a different position
    np.testing.assert_allclose([fr.s[0], fr.t[0]], [0.25, 0.25])


def test_boundary_edges_are_the_unshared_edges_in_triangle_order():
    F = np.array([[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(boundary_edges(F), [[0, 1], [1, 2], [2, 3], [3, 0]])


@pytest.mark.parametrize("use_edges", [True, False])
def test_exterior_points_follow_a_rigid_motion_exactly(star_mesh, use_edges):
    V, F, _, S = star_mesh
    rng = np.random.default_rng(3)
    outward = (S - CENTRE) / np.linalg.norm(S - CENTRE, axis=1, keepdims=True)
    e = S + outward * rng.uniform(-3, 3, size=(len(S), 1)) + rng.normal(scale=1.0, size=S.shape)
    fr = exterior_frame(V, e, F if use_edges else None)
    np.testing.assert_allclose(exterior_positions(V, fr), e, atol=1e-9)
    R, t = rot(0.8), np.array([-35.0, 12.5])
    np.testing.assert_allclose(exterior_positions(V @ R.T + t, fr), e @ R.T + t, atol=1e-9)
    # and a uniform scale with it (similarity)
    np.testing.assert_allclose(exterior_positions(2.5 * V @ R.T + t, fr), 2.5 * e @ R.T + t, atol=1e-9)


def test_exterior_point_on_a_vertex_is_exactly_that_vertex(star_mesh):
    V, F, _, _ = star_mesh
    bv = boundary_vertices(F)[::7]
    fr = exterior_frame(V, V[bv], F)
    rng = np.random.default_rng(0)
    for scale in (5.0, 1e4):
        U = V + rng.normal(scale=scale, size=V.shape)
        np.testing.assert_array_equal(exterior_positions(U, fr), U[bv])


def test_exterior_points_ride_along_an_arap_bend():
    # a bar bent by ARAP: points 2 px outside its contour stay about 2 px outside
    W, H = 200.0, 40.0
    ring = np.array([[0.0, 0.0], [W, 0.0], [W, H], [0.0, H]]) + 50
    pins = np.array([[60.0, 70.0], [240.0, 70.0]])
    M = triangulate_regions([Region(ring)], max_area=15.0, points=pins)
    b = np.array([np.flatnonzero(np.all(M.V == p, axis=1))[0] for p in pins])
    x = np.linspace(60, 240, 10)
    e = np.r_[np.c_[x, np.full(10, 48.0)], np.c_[x, np.full(10, 92.0)]]  # 2 px above / below
    fr = exterior_frame(M.V, e, M.F)
    U = arap_solve(arap_precompute(M.V, M.F, b), [[60.0, 70.0], [200.0, 0.0]], iterations=30)
    E = exterior_positions(U, fr)
    BE = boundary_edges(M.F)
    A, B = U[BE[:, 0]], U[BE[:, 1]]
    d = B - A
    u = np.clip(np.einsum("jbk,bk->jb", E[:, None] - A, d) / np.einsum("bk,bk->b", d, d), 0, 1)
    gap = np.linalg.norm(E[:, None] - (A + u[..., None] * d), axis=2).min(axis=1)
    assert np.abs(U[b[1]] - [200.0, 0.0]).max() < 1e-6  # it did bend
    assert np.all(np.abs(gap - 2.0) < 0.5)


# --- fine mode ---------------------------------------------------------------------------

@pytest.mark.parametrize("mode", ["points", "lines"])
def test_fine_mode_identity_without_exterior_motion(star_mesh, mode):
    V, F, pin, S = star_mesh
    np.testing.assert_array_equal(fine_deform(V, F, pin, S, S.copy(), mode=mode), V)
    assert fine_deform(V, F, pin, np.zeros((0, 2)), np.zeros((0, 2))).shape == V.shape


@pytest.mark.parametrize("distance", ["geodesic", "euclidean"])
@pytest.mark.parametrize("mode", ["points", "lines"])
def test_dragging_one_exterior_point_pulls_the_boundary_near_it_only(star_mesh, mode, distance):
    V, F, pin, S = star_mesh
    outward = (S - CENTRE) / np.linalg.norm(S - CENTRE, axis=1, keepdims=True)
    e = S + 1.5 * outward  # near the contour, not on a vertex
    drag = np.array([18.0, -12.0])
    tgt = e.copy()
    tgt[0] += drag
    U = fine_deform(V, F, pin, e, tgt, mode=mode, distance=distance)
    moved = np.linalg.norm(U - V, axis=1) / np.linalg.norm(drag)
    bv = boundary_vertices(F)
    near = bv[np.argmin(np.linalg.norm(V[bv] - e[0], axis=1))]
    assert moved[near] > 0.5
    assert np.dot(U[near] - V[near], drag) > 0.5 * np.dot(drag, drag)  # toward the drag
    f = default_falloff(V, F, e)
    # control lines reach on to the neighbouring exterior points (~2 f away): 1 f more
    far = np.linalg.norm(V - e[0], axis=1) > (2.5 if mode == "points" else 3.5) * f
    assert far.sum() > len(V) // 4
    assert moved[far].max() < 0.02
    assert moved[depth_from_boundary(V, F) > f].max() == 0.0  # deep interior: anchored
    np.testing.assert_array_equal(U[pin], V[pin])


@pytest.mark.parametrize("mode", ["points", "lines"])
def test_exterior_point_on_a_vertex_lands_exactly_on_its_target(star_mesh, mode):
    V, F, pin, S = star_mesh
    bv = boundary_vertices(F)
    k = np.array([bv[np.argmin(np.linalg.norm(V[bv] - s, axis=1))] for s in S])
    e = V[k]
    tgt = e + np.random.default_rng(5).normal(scale=4.0, size=e.shape)
    U = fine_deform(V, F, pin, e, tgt, mode=mode)
    np.testing.assert_array_equal(U[k], tgt)


@pytest.fixture(scope="module")
def square_mesh():
    ring = np.array([[0.0, 0.0], [160.0, 0.0], [160.0, 160.0], [0.0, 160.0]]) + 20
    M = triangulate_regions([Region(ring)], max_area=10.0, points=[[100.0, 100.0]])
    pin = np.flatnonzero(np.all(M.V == [100.0, 100.0], axis=1))
    # exterior points at the corners and the middles of the sides, in contour order
    e = np.array([[20, 20], [100, 20], [180, 20], [180, 100], [180, 180], [100, 180], [20, 180],
                  [20, 100]], float)
    tgt = e.copy()
    tgt[1] += [0.0, -16.0]  # pull the middle of the top side up
    return M.V, M.F, pin, e, tgt


def test_lines_interpolate_the_drag_along_a_straight_side(square_mesh):
    V, F, pin, e, tgt = square_mesh
    bv = boundary_vertices(F)
    top = bv[(np.abs(V[bv, 1] - 20) < 1e-6) & (V[bv, 0] > 20) & (V[bv, 0] < 100)]
    frac = (V[top, 0] - 20) / 80  # position between the corner (0) and the middle (1)
    U = fine_deform(V, F, pin, e, tgt, mode="lines")
    # the top side follows the control line: displacement ~ linear in the position
    np.testing.assert_allclose(-(U[top, 1] - 20) / 16, frac, atol=0.1)
    Up = fine_deform(V, F, pin, e, tgt, mode="points")
    quarter = top[np.argmin(np.abs(frac - 0.5))]
    assert abs(-(Up[quarter, 1] - 20) / 16 - 0.5) > abs(-(U[quarter, 1] - 20) / 16 - 0.5)


def test_a_dragged_point_makes_a_bump_about_falloff_wide(square_mesh):
    V, F, pin, e, tgt = square_mesh
    f = default_falloff(V, F, e)
    assert f == pytest.approx(40.0)
    bv = boundary_vertices(F)
    top = bv[np.abs(V[bv, 1] - 20) < 1e-6]
    U = fine_deform(V, F, pin, e, tgt, mode="points")
    up = -(U[top, 1] - 20) / 16
    side = np.abs(V[top, 0] - 100)  # distance from the dragged point along the side
    assert up[side < f / 2].min() > 0.4
    assert up[side > 1.5 * f].max() < 0.15


@pytest.mark.parametrize("mode", ["points", "lines"])
def test_the_band_joins_the_still_interior_without_a_crease(square_mesh, mode):
    V, F, pin, e, tgt = square_mesh
    f = default_falloff(V, F, e)
    band = depth_from_boundary(V, F) <= f
    E = edges(F)
    cross = E[band[E[:, 0]] != band[E[:, 1]]]
    inner = np.where(band[cross[:, 0]], cross[:, 0], cross[:, 1])  # band side of the front
    U = fine_deform(V, F, pin, e, tgt, mode=mode)
    assert np.linalg.norm(U - V, axis=1)[inner].max() < 0.02 * 16
    np.testing.assert_array_equal(U[~band], V[~band])


def test_a_pin_near_an_exterior_point_holds_only_itself():
    ring = np.array([[0.0, 0.0], [160.0, 0.0], [160.0, 160.0], [0.0, 160.0]]) + 20
    M = triangulate_regions([Region(ring)], max_area=10.0, points=[[100.0, 32.0]])
    V, F = M.V, M.F
    pin = np.flatnonzero(np.all(V == [100.0, 32.0], axis=1))
    e = np.array([[20, 20], [102.5, 18.5], [180, 20], [180, 180], [20, 180]], float)  # e1 off-vertex
    tgt = e.copy()
    tgt[1] += [0.0, -10.0]
    U = fine_deform(V, F, pin, e, tgt)
    bv = boundary_vertices(F)
    near = bv[np.argmin(np.linalg.norm(V[bv] - e[1], axis=1))]
    assert U[near, 1] - V[near, 1] < -8.0
    np.testing.assert_array_equal(U[pin], V[pin])


def test_geodesic_weights_do_not_pull_across_a_gap():
    # a U: two prongs 6 px apart; drag a point on the inner side of the left prong
    ring = np.array([[0, 0], [60, 0], [60, 200], [66, 200], [66, 0], [126, 0], [126, 260],
                     [0, 260]], float) + 10
    M = triangulate_regions([Region(ring)], max_area=12.0, points=[[63.0, 250.0]])
    V, F = M.V, M.F
    pin = np.flatnonzero(np.all(V == [63.0, 250.0], axis=1))
    e = np.array([[70.0, 60.0], [70.0, 200.0], [10.0, 10.0], [76.0, 60.0], [136.0, 10.0]])
    tgt = e.copy()
    tgt[0] += [-10.0, 0.0]
    right = (V[:, 0] > 73) & (V[:, 1] < 120)  # the other prong, across the gap
    Ug = fine_deform(V, F, pin, e, tgt, distance="geodesic")
    Ue = fine_deform(V, F, pin, e, tgt, distance="euclidean")
    moved_g = np.linalg.norm(Ug - V, axis=1)[right].max() / 10
    moved_e = np.linalg.norm(Ue - V, axis=1)[right].max() / 10
    assert moved_g < 0.02
    assert moved_e > 0.1  # image space reaches across


def test_radius_bounds_the_reach(star_mesh):
    V, F, pin, S = star_mesh
    tgt = S.copy()
    tgt[0] += [0.0, -20.0]
    U = fine_deform(V, F, pin, S, tgt, radius=50.0, distance="euclidean")
    beyond = np.linalg.norm(V - S[0], axis=1) > 50.0
    np.testing.assert_array_equal(U[beyond], V[beyond])
    assert np.abs(U[~beyond] - V[~beyond]).max() > 10


def test_default_falloff_is_half_the_exterior_spacing(star_mesh):
    V, F, _, _ = star_mesh
    square = np.array([[170.0, 170.0], [230.0, 170.0], [230.0, 230.0], [170.0, 230.0]])
    assert default_falloff(V, F, square) == pytest.approx(30.0)
    h = np.median(np.linalg.norm(np.diff(V[boundary_edges(F)], axis=1)[:, 0], axis=1))
    assert default_falloff(V, F, square[:2] * 0.01) == pytest.approx(2 * h)  # floor


def test_bad_options(star_mesh):
    V, F, pin, S = star_mesh
    with pytest.raises(ValueError):
        fine_deform(V, F, pin, S, S + 1, mode="curves")
    with pytest.raises(ValueError):
        fine_deform(V, F, pin, S, S[:3])
