"""Relaxed ARAP: extreme drags come out with no folded triangles."""
import numpy as np
import pytest
import triangle

import puppet.deform.factor as factor
import puppet.deform.relax as relax
from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.relax import folded_triangles, relax_foldovers, untangle


def mesh(P, max_area):
    P = np.asarray(P, float)
    seg = np.c_[np.arange(len(P)), (np.arange(len(P)) + 1) % len(P)]
    T = triangle.triangulate({"vertices": P, "segments": seg}, f"pq30a{max_area}Q")
    return T["vertices"], T["triangles"]


def nearest(V, x):
    return int(np.argmin(np.linalg.norm(V - np.asarray(x, float), axis=1)))


def turned(p, centre, degrees):
    t = np.radians(degrees)
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return (np.asarray(p, float) - centre) @ R.T + centre


@pytest.fixture(scope="module")
def bar():
    """100 x 20 bar held by two pins at its left end, a third pin at its right end."""
    V, F = mesh([[0, 0], [100, 0], [100, 20], [0, 20]], 8)
    b = np.array([nearest(V, [0, 0]), nearest(V, [0, 20]), nearest(V, [100, 10])])
    return V, F, b, arap_precompute(V, F, b)


@pytest.fixture(scope="module")
def square():
    """60 x 60 square with two fixed pins at mid-height and a third pin above them."""
    V, F = mesh([[0, 0], [60, 0], [60, 60], [0, 60]], 8)
    b = np.array([nearest(V, [10, 30]), nearest(V, [50, 30]), nearest(V, [30, 50])])
    return V, F, b, arap_precompute(V, F, b)


def check_relaxed(d, bc):
    """Plain ARAP folds; relaxed: no fold, pins exact, no factorisation, U untouched."""
    U = arap_solve(d, bc)
    assert len(folded_triangles(d.V, U, d.F)) > 0, "plain ARAP folds on this drag"
    U_copy = U.copy()
    before = factor.FACTORIZATIONS
    R = relax_foldovers(d, U, bc)
    assert factor.FACTORIZATIONS == before, "relaxing never refactorises"
    assert np.array_equal(U, U_copy), "the input is not modified"
    assert len(folded_triangles(d.V, R, d.F)) == 0
    assert np.array_equal(R[d.b], bc)
    assert np.isfinite(R).all()
    return U, R


def test_folded_triangles_hand_case():
    V = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    F = np.array([[0, 1, 2], [1, 3, 2]])
    U = V.copy()
    U[3] = [0.2, 0.2]  # pushed over the shared edge: the second triangle flips
    assert folded_triangles(V, U, F).tolist() == [1]
    assert folded_triangles(V, V, F).tolist() == []
    U[3] = [0.5, 0.5]  # onto the shared edge: zero area counts as folded
    assert folded_triangles(V, U, F).tolist() == [1]
    Vd = V.copy()
    Vd[3] = [0.5, 0.5]  # degenerate at rest: never counted
    assert folded_triangles(Vd, U, F).tolist() == []


@pytest.mark.parametrize("target", [[20, 10], [5, 10], [60, 10], [-30, 10], [-100, 10], [0, 10.5]])
def test_end_pin_dragged_back_through_the_bar(bar, target):
    V, F, b, d = bar
    check_relaxed(d, np.array([V[b[0]], V[b[1]], target]))


@pytest.mark.parametrize("degrees", [120, 170, -170, 180])
def test_end_pin_turned_about_the_held_end(bar, degrees):
    V, F, b, d = bar
    check_relaxed(d, np.array([V[b[0]], V[b[1]], turned(V[b[2]], [0, 10], degrees)]))


@pytest.mark.parametrize("target", [[30, -20], [70, 30], [12, 30.5], [20, 30]])
def test_pin_dragged_against_two_fixed_pins(square, target):
    V, F, b, d = square
    check_relaxed(d, np.array([V[b[0]], V[b[1]], target]))


def test_similarity_rounds_alone_remove_some_folds(bar):
    """Stage 1 by itself (no untangling) clears some folding drags, reusing the factor."""
    V, F, b, d = bar
    cleared = tried = 0
    for target in ([5, 10], [20, 10], [60, 10], turned(V[b[2]], [0, 10], -170), turned(V[b[2]], [0, 10], 170)):
        bc = np.array([V[b[0]], V[b[1]], target])
        U = arap_solve(d, bc)
        if len(folded_triangles(V, U, F)) == 0:
            continue
        tried += 1
        before = factor.FACTORIZATIONS
        R = relax_foldovers(d, U, bc, untangle_folds=False)
        assert factor.FACTORIZATIONS == before
        assert np.array_equal(R[b], bc)
        assert len(folded_triangles(V, R, F)) <= len(folded_triangles(V, U, F))
        cleared += len(folded_triangles(V, R, F)) == 0
    assert tried >= 2 and cleared >= 1, (tried, cleared)


def test_fold_free_pose_is_returned_unchanged(bar):
    V, F, b, d = bar
    bc = np.array([V[b[0]], V[b[1]], [90, -20]])
    U = arap_solve(d, bc)
    assert len(folded_triangles(V, U, F)) == 0
    U_copy = U.copy()
    assert relax_foldovers(d, U, bc) is U
    assert np.array_equal(U, U_copy)


def test_rest_pins_give_the_rest_mesh(bar):
    V, F, b, d = bar
    U = arap_solve(d, V[b])
    R = relax_foldovers(d, U, V[b])
    assert np.abs(R - V).max() < 1e-9
    assert relax_foldovers(d, V.copy(), V[b]).tolist() == V.tolist()


def test_random_drags_come_out_fold_free(bar):
    V, F, b, d = bar
    rng = np.random.default_rng(5)
    folded_before = 0
    for _ in range(6):
        bc = np.array([V[b[0]], V[b[1]], rng.uniform([-150, -100], [150, 120])])
        U = arap_solve(d, bc)
        folded_before += len(folded_triangles(V, U, F)) > 0
        R = relax_foldovers(d, U, bc)
        assert len(folded_triangles(V, R, F)) == 0
        assert np.array_equal(R[b], bc)
    assert folded_before >= 2  # the draw does exercise the relaxation


@pytest.mark.parametrize("whole", [False, True])
def test_pinless_component_stays_at_rest(monkeypatch, whole):
    V1, F1 = mesh([[0, 0], [100, 0], [100, 20], [0, 20]], 8)
    V2, F2 = mesh([[0, 40], [30, 40], [30, 60], [0, 60]], 8)
    V, F = np.r_[V1, V2], np.r_[F1, F2 + len(V1)]
    b = np.array([nearest(V1, [0, 0]), nearest(V1, [0, 20]), nearest(V1, [100, 10])])
    d = arap_precompute(V, F, b)
    bc = np.array([V[b[0]], V[b[1]], [20, 10]])  # needs the untangling stage
    if whole:  # straight to the whole-mesh untangling
        monkeypatch.setattr(relax, "UNTANGLE_RINGS", ())
    U, R = check_relaxed(d, bc)
    assert np.array_equal(R[len(V1):], V2)


def test_pins_land_on_the_targets_given(bar):
    """Even when U was solved for slightly different targets."""
    V, F, b, d = bar
    bc = np.array([V[b[0]], V[b[1]], [5, 10]])
    U = arap_solve(d, bc + [[0, 0], [0, 0], [0.25, -0.25]])
    R = relax_foldovers(d, U, bc)
    assert np.array_equal(R[b], bc)
    assert len(folded_triangles(V, R, F)) == 0


def test_unreachable_targets_never_add_folds():
    """Three pins of one triangle given reversed targets: that fold cannot go."""
    V, F = mesh([[0, 0], [40, 0], [40, 40], [0, 40]], 20)
    t = int(np.argmin(np.linalg.norm(V[F].mean(axis=1) - [20, 20], axis=1)))
    b = F[t].copy()
    d = arap_precompute(V, F, b)
    bc = V[b][[0, 2, 1]]  # two corners swapped: the triangle is reflected
    U = arap_solve(d, bc)
    n0 = len(folded_triangles(V, U, F))
    R = relax_foldovers(d, U, bc)
    n1 = len(folded_triangles(V, R, F))
    assert t in folded_triangles(V, R, F)
    assert n1 <= n0
    assert np.array_equal(R[b], bc) and np.isfinite(R).all()


def test_untangle_hand_case():
    """A hexagon fan whose centre was dragged outside: only the centre moves, back inside."""
    a = np.arange(6) * np.pi / 3
    V = np.r_[[[0.0, 0.0]], np.c_[np.cos(a), np.sin(a)]]
    F = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    U = V.copy()
    U[0] = [1.6, 0.3]
    assert len(folded_triangles(V, U, F)) > 0
    X = untangle(V, F, U, [0])
    assert len(folded_triangles(V, X, F)) == 0
    assert np.array_equal(X[1:], V[1:])
    assert np.linalg.norm(X[0]) < 0.2  # the symmetric ring pulls it to the middle
    assert np.array_equal(U[0], [1.6, 0.3])  # input untouched
