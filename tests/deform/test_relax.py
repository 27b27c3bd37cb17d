"""Relaxed ARAP: extreme drags come out with no folded triangles."""
import numpy as np
import pytest
import triangle

import puppet.deform.factor as factor
from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.relax import folded_triangles, relax_foldovers


@pytest.fixture(scope="module")
def bar():
    P = np.array([[0, 0], [100, 0], [100, 20], [0, 20]], float)
    seg = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    T = triangle.triangulate({"vertices": P, "segments": seg}, "pq30a8Q")
    V, F = T["vertices"], T["triangles"]

    def nearest(x):
        return int(np.argmin(np.linalg.norm(V - x, axis=1)))
    b = np.array([nearest([0, 0]), nearest([0, 20]), nearest([100, 10])])
    return V, F, b, arap_precompute(V, F, b)


def test_folded_triangles_hand_case():
    V = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    F = np.array([[0, 1, 2], [1, 3, 2]])
    U = V.copy()
    U[3] = [0.2, 0.2]  # pushed over the shared edge: the second triangle flips
    assert folded_triangles(V, U, F).tolist() == [1]
    assert folded_triangles(V, V, F).tolist() == []


@pytest.mark.parametrize("target", [[20, 10], [5, 10], [60, 10], [-30, 10], [-100, 10], [0, 10.5]])
def test_extreme_drags_fold_without_and_not_with_relax(bar, target):
    V, F, b, d = bar
    bc = np.array([V[b[0]], V[b[1]], target])
    U = arap_solve(d, bc)
    assert len(folded_triangles(V, U, F)) > 0, "plain ARAP folds on this drag"
    before = factor.FACTORIZATIONS
    R = relax_foldovers(d, U, bc)
    assert factor.FACTORIZATIONS == before, "relaxing never refactorises"
    assert len(folded_triangles(V, R, F)) == 0
    assert np.array_equal(R[b], bc)


def test_fold_free_pose_is_returned_unchanged(bar):
    V, F, b, d = bar
    bc = np.array([V[b[0]], V[b[1]], [90, -20]])
    U = arap_solve(d, bc)
    assert len(folded_triangles(V, U, F)) == 0
    assert relax_foldovers(d, U, bc) is U
    assert relax_foldovers(d, V.copy(), V[b]).tolist() == V.tolist()


def test_never_returns_more_folds_than_given(bar):
    V, F, b, d = bar
    rng = np.random.default_rng(5)
    for _ in range(5):
        bc = np.array([V[b[0]], V[b[1]], rng.uniform([-150, -100], [150, 120])])
        U = arap_solve(d, bc)
        R = relax_foldovers(d, U, bc)
        assert len(folded_triangles(V, R, F)) <= len(folded_triangles(V, U, F))
        assert np.array_equal(R[b], bc)
