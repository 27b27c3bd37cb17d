import numpy as np
import pytest

import puppet.deform.factor as factor_mod
from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.igarashi import (IgarashiData, edge_neighbourhoods, edge_similarities,
                                    igarashi_precompute, igarashi_solve)
from tests.deform.meshes import l_shape, nearest, rectangle, rot







def signed_areas(U, F):
    a, b, c = U[F[:, 0]], U[F[:, 1]], U[F[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def edge_ratios(V, E, U):
    return np.linalg.norm(U[E[:, 1]] - U[E[:, 0]], axis=1) / np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)


V_L, F_L = l_shape()
B_L = nearest(V_L, [[1, 1], [19, 1], [1, 19], [19, 7]])
BC_DRAG = V_L[B_L] + np.array([[0.0, 0.0], [-6.0, 9.0], [7.0, -2.0], [1 / 3, 2 / 7]])


# --- reference energies written straight from the paper's G_k formulation (loops) ----

def neighbourhoods_by_loop(F):
    """{(i, j): [i, j, opposite vertices...]} built with plain Python."""
    nb = {}
    for t in F:
        for c in range(3):
            i, j, o = t[(c + 1) % 3], t[(c + 2) % 3], t[c]
            key = (min(i, j), max(i, j))
            nb.setdefault(key, list(key)).append(o)
    return nb


def fit_similarity_gk(V, U, verts):
    """(a, b) of T = [[a, -b], [b, a]] and t minimising sum |T v + t - u|^2 (lstsq on G_k)."""
    G = np.zeros((2 * len(verts), 4))
    rhs = np.zeros(2 * len(verts))
    for r, m in enumerate(verts):
        x, y = V[m]
        G[2 * r] = [x, -y, 1, 0]
        G[2 * r + 1] = [y, x, 0, 1]
        rhs[2 * r:2 * r + 2] = U[m]
    sol = np.linalg.lstsq(G, rhs, rcond=None)[0]
    return sol[0], sol[1]


def energy1(V, F, U):
    E = 0.0
    for (i, j), verts in neighbourhoods_by_loop(F).items():
        a, b = fit_similarity_gk(V, U, verts)
        e = V[j] - V[i]
        E += np.sum((U[j] - U[i] - np.array([[a, -b], [b, a]]) @ e) ** 2)
    return E


def rotations_from(V, F, U1):
    R = {}
    for (i, j), verts in neighbourhoods_by_loop(F).items():
        a, b = fit_similarity_gk(V, U1, verts)
        r = np.hypot(a, b)
        R[(i, j)] = np.array([[a, -b], [b, a]]) / r
    return R


def energy2(V, R, U):
    return sum(np.sum((U[j] - U[i] - Rk @ (V[j] - V[i])) ** 2) for (i, j), Rk in R.items())


# --- tiny hand-checked case ----------------------------------------------------------

def test_single_triangle_by_hand():
    # pins 0 -> (0, 0), 1 -> (0, 2): a rotation by 90 degrees and a scale of 2.
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    data = igarashi_precompute(V, np.array([[0, 1, 2]]), [0, 1])
    bc = np.array([[0.0, 0.0], [0.0, 2.0]])
    # step 1: the same similarity moves vertex 2 to (-2, 0)
    np.testing.assert_allclose(igarashi_solve(data, bc, steps=1)[2], [-2.0, 0.0], atol=1e-12)
    # step 2: every edge fit is the 90 degree rotation R; u2 averages u0 + R(v2 - v0) =
    # (-1, 0) and u1 + R(v2 - v1) = (0, 2) + (-1, -1) = (-1, 1)
    np.testing.assert_allclose(igarashi_solve(data, bc)[2], [-1.0, 0.5], atol=1e-12)


def test_edge_neighbourhoods_interior_four_boundary_three():
    # unit square split along the diagonal 0-2
    F = np.array([[0, 1, 2], [0, 2, 3]])
    E, k, m = edge_neighbourhoods(F, 4)
    members = {tuple(E[e]): sorted(m[k == e].tolist()) for e in range(len(E))}
    assert members == {(0, 1): [0, 1, 2], (0, 2): [0, 1, 2, 3], (0, 3): [0, 2, 3],
                       (1, 2): [0, 1, 2], (2, 3): [0, 2, 3]}


def test_similarity_fit_matches_gk_least_squares():
    rng = np.random.default_rng(1)
    data = igarashi_precompute(V_L, F_L, B_L)
    U = V_L @ rot(0.3).T * 1.7 + rng.normal(scale=0.4, size=V_L.shape)
    am1, bb = edge_similarities(data, U)
    nb = neighbourhoods_by_loop(F_L)
    for e in rng.choice(len(data.E), 40, replace=False):
        a, b = fit_similarity_gk(V_L, U, nb[tuple(data.E[e])])
        assert abs(am1[e] + 1 - a) < 1e-10 and abs(bb[e] - b) < 1e-10


# --- identities ----------------------------------------------------------------------

@pytest.mark.parametrize("steps", [1, 2])
def test_rest_targets_give_rest_mesh(steps):
    data = igarashi_precompute(V_L, F_L, B_L)
    U = igarashi_solve(data, V_L[B_L], steps=steps)
    assert np.abs(U - V_L).max() < 1e-9


@pytest.mark.parametrize("steps", [1, 2])
def test_pinned_vertices_exactly_at_targets(steps):
    data = igarashi_precompute(V_L, F_L, B_L)
    U = igarashi_solve(data, BC_DRAG, steps=steps)
    np.testing.assert_array_equal(U[B_L], BC_DRAG)
    assert np.abs(U - V_L).max() > 1.0  # a real deformation


@pytest.mark.parametrize("steps", [1, 2])
def test_rigid_motion_of_pins_moves_whole_mesh_rigidly(steps):
    b = B_L[:3]  # three non-collinear pins
    data = igarashi_precompute(V_L, F_L, b)
    R, t = rot(np.radians(40.0)), np.array([40.0, -15.0])
    U = igarashi_solve(data, V_L[b] @ R.T + t, steps=steps)
    assert np.abs(U - (V_L @ R.T + t)).max() < 1e-6 * np.ptp(V_L)


def test_no_pins_gives_rest():
    data = igarashi_precompute(V_L, F_L, [])
    assert data.factor1 is None
    np.testing.assert_array_equal(igarashi_solve(data, np.zeros((0, 2))), V_L)


# --- the two energies are minimised --------------------------------------------------

def test_step1_minimises_similarity_energy():
    V, F = l_shape(6.0)
    b = nearest(V, [[1, 1], [19, 1], [1, 19]])
    bc = V[b] + np.array([[0.0, 0.0], [-5.0, 8.0], [6.0, -2.0]])
    U = igarashi_solve(igarashi_precompute(V, F, b), bc, steps=1)
    d = np.random.default_rng(2).normal(size=V.shape)
    d[b] = 0.0
    for eps in (1e-2, 1.0):
        ep, em, e0 = energy1(V, F, U + eps * d), energy1(V, F, U - eps * d), energy1(V, F, U)
        assert ep - e0 > 0 and em - e0 > 0
        # a quadratic has no linear term at its minimum
        assert abs(ep - em) < 1e-7 * (ep + em - 2 * e0)


def test_step2_minimises_edge_energy_with_fitted_rotations():
    V, F = l_shape(6.0)
    b = nearest(V, [[1, 1], [19, 1], [1, 19]])
    bc = V[b] + np.array([[0.0, 0.0], [-5.0, 8.0], [6.0, -2.0]])
    data = igarashi_precompute(V, F, b)
    R = rotations_from(V, F, igarashi_solve(data, bc, steps=1))
    U = igarashi_solve(data, bc)
    d = np.random.default_rng(3).normal(size=V.shape)
    d[b] = 0.0
    ep, em, e0 = energy2(V, R, U + d), energy2(V, R, U - d), energy2(V, R, U)
    assert ep - e0 > 0 and em - e0 > 0
    assert abs(ep - em) < 1e-7 * (ep + em - 2 * e0)


# --- scale adjustment ----------------------------------------------------------------

def test_uniform_scaling_of_pins_step1_scales_step2_does_not():
    V, F = l_shape(0.5)
    b = nearest(V, [[1, 1], [19, 1], [1, 19], [19, 7]])
    c = V[b].mean(axis=0)
    bc = c + 1.5 * (V[b] - c)
    data = igarashi_precompute(V, F, b)
    U1 = igarashi_solve(data, bc, steps=1)
    U2 = igarashi_solve(data, bc)
    assert np.abs(U1 - (c + 1.5 * (V - c))).max() < 1e-6 * np.ptp(V)  # whole mesh scaled
    strain1 = np.abs(edge_ratios(V, data.E, U1) - 1).mean()
    strain2 = np.abs(edge_ratios(V, data.E, U2) - 1).mean()
    assert abs(strain1 - 0.5) < 1e-6
    assert strain2 < 0.6 * strain1
    # as close to rest lengths as a converged ARAP gets on the same pins
    Ua = arap_solve(arap_precompute(V, F, b, weights="uniform"), bc, iterations=100)
    assert strain2 < 1.15 * np.abs(edge_ratios(V, data.E, Ua) - 1).mean()


def test_stretching_a_bar_keeps_its_width():
    V, F = rectangle(40, 6, 0.5)
    b = nearest(V, [[3, 3], [37, 3]])
    c = V[b].mean(axis=0)
    data = igarashi_precompute(V, F, b)
    mid = np.abs(V[:, 0] - 20) < 1.5
    top, bot = mid & (V[:, 1] > 6 - 1e-9), mid & (V[:, 1] < 1e-9)
    assert top.any() and bot.any()
    widths = {}
    for steps in (1, 2):
        U = igarashi_solve(data, c + 1.5 * (V[b] - c), steps=steps)
        widths[steps] = U[top, 1].mean() - U[bot, 1].mean()
    assert abs(widths[1] - 9.0) < 1e-6
    assert abs(widths[2] - 6.0) < 0.05 * 6.0


# --- precompute / solve split --------------------------------------------------------

def test_drag_does_not_refactorise():
    before = factor_mod.FACTORIZATIONS
    data = igarashi_precompute(V_L, F_L, B_L)
    assert factor_mod.FACTORIZATIONS == before + 2  # step 1 and step 2, once each
    for s in np.linspace(0.0, 1.0, 6):
        U = igarashi_solve(data, V_L[B_L] + s * (BC_DRAG - V_L[B_L]))
        igarashi_solve(data, V_L[B_L] + s * (BC_DRAG - V_L[B_L]), steps=1)
    assert factor_mod.FACTORIZATIONS == before + 2
    np.testing.assert_array_equal(U[B_L], BC_DRAG)


def test_same_pins_same_mesh():
    # a pose depends only on its pins, not on earlier solves (no state kept in data)
    data = igarashi_precompute(V_L, F_L, B_L)
    U = igarashi_solve(data, BC_DRAG).copy()
    igarashi_solve(data, 2 * BC_DRAG)
    np.testing.assert_array_equal(igarashi_solve(data, BC_DRAG), U)
    np.testing.assert_array_equal(data.V, V_L)


# --- components ----------------------------------------------------------------------

def two_pieces():
    Vr, Fr = rectangle(10, 4, 1.0)
    V = np.r_[V_L, Vr + [30.0, 0.0]]
    F = np.r_[F_L, Fr + len(V_L)]
    return V, F


def test_unpinned_component_stays_at_rest():
    V, F = two_pieces()
    data = igarashi_precompute(V, F, B_L)
    U = igarashi_solve(data, BC_DRAG)
    rest = np.arange(len(V_L), len(V))
    np.testing.assert_array_equal(U[rest], V[rest])
    np.testing.assert_array_equal(U[B_L], BC_DRAG)
    assert np.abs(U[:len(V_L)] - V_L).max() > 1.0


def test_single_pin_component_translates():
    V, F = two_pieces()
    pin2 = len(V_L) + 5
    b = np.r_[B_L, pin2]
    bc = np.r_[BC_DRAG, V[[pin2]] + [[3.0, -2.0]]]
    U = igarashi_solve(igarashi_precompute(V, F, b), bc)
    second = np.arange(len(V_L), len(V))
    np.testing.assert_allclose(U[second], V[second] + [3.0, -2.0], atol=1e-12)
    np.testing.assert_array_equal(U[b], bc)


# --- a bending drag ------------------------------------------------------------------

@pytest.mark.parametrize("angle", [30.0, 60.0, 90.0])
def test_bending_a_bar_has_no_foldovers_and_keeps_area(angle):
    V, F = rectangle(100, 20, 4.0)
    left = np.flatnonzero(V[:, 0] < 1e-9)
    right = np.flatnonzero(V[:, 0] > 100 - 1e-9)
    b = np.r_[left, right]
    # right end: rigidly carried along a circular arc of the bar's length
    th = np.radians(angle)
    radius = 100.0 / th
    end = np.array([radius * np.sin(th), 10.0 + radius * (1 - np.cos(th))])
    bc = np.r_[V[left], (V[right] - [100.0, 10.0]) @ rot(th).T + end]
    data = igarashi_precompute(V, F, b)
    U = igarashi_solve(data, bc)
    A0, A = signed_areas(V, F), signed_areas(U, F)
    assert np.all(np.sign(A) == np.sign(A0)), "folded triangles"
    assert abs(A.sum() / A0.sum() - 1) < 0.10
    # and the bar really bent: its middle rose most of the way to the arc's
    assert U[nearest(V, [[50, 10]])[0], 1] > 10.0 + 0.75 * radius * (1 - np.cos(th / 2))


# --- errors --------------------------------------------------------------------------

def test_bad_arguments():
    data = igarashi_precompute(V_L, F_L, B_L)
    assert isinstance(data, IgarashiData)
    with pytest.raises(ValueError):
        igarashi_solve(data, BC_DRAG, steps=3)
    with pytest.raises(ValueError):
        igarashi_solve(data, BC_DRAG[:2])
    with pytest.raises(ValueError):
        igarashi_precompute(V_L, F_L, B_L, solver="magic")
    with pytest.raises(ValueError):
        igarashi_precompute(V_L, F_L, [0, 0])


def test_piece_hanging_on_one_vertex_is_reported_singular():
    # bow-tie: the unpinned triangle may rotate and scale freely about vertex 0
    V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [-1.0, 0.0], [-1.0, -1.0]])
    with pytest.raises(ValueError, match="singular"):
        igarashi_precompute(V, np.array([[0, 1, 2], [0, 3, 4]]), [1, 2])
