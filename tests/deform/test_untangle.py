"""The untangling energy's derivatives and the work budget of the relaxation."""
import numpy as np
import pytest
import scipy.sparse as sp

from puppet.deform import budget as cost
from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.budget import Budget
from puppet.deform.relax import default_budget, folded_triangles, relax_foldovers
from puppet.deform.untangle import THETA, _chi, _Energy, _modes, untangle
from tests.deform.meshes import nearest, rectangle


def element_hessian(j, eps):
    """The 4x4 Hessian of N / chi(det J) in vec(J), by the chain rule (no eigensystem)."""
    a, b, c, d = j
    D = a * d - b * c
    h = np.sqrt(eps * eps + D * D)
    ch, d1, d2 = _chi(np.array(D), eps), 0.5 + 0.5 * D / h, 0.5 * eps * eps / h ** 3
    N = (1 - THETA) * (j @ j) + THETA * (1 + D * D)
    gD = np.array([d, -c, -b, a])
    HD = np.array([[0, 0, 0, 1], [0, 0, -1, 0], [0, -1, 0, 0], [1, 0, 0, 0]], float)
    gN = 2 * (1 - THETA) * j + 2 * THETA * D * gD
    HN = 2 * (1 - THETA) * np.eye(4) + 2 * THETA * (np.outer(gD, gD) + D * HD)
    gc, Hc = d1 * gD, d2 * np.outer(gD, gD) + d1 * HD
    return (HN / ch - (np.outer(gN, gc) + np.outer(gc, gN)) / ch ** 2 - N * Hc / ch ** 2
            + 2 * N * np.outer(gc, gc) / ch ** 3)


@pytest.mark.parametrize("eps", [1.0, 1e-3, 1e-10])
def test_closed_form_eigensystem_matches_the_hessian(eps):
    rng = np.random.default_rng(0)
    J = rng.normal(size=(300, 4)) * rng.uniform(0.01, 10, (300, 1))
    J[:6] = [[1, 0, 0, 1], [2, 0, 0, 2], [1, 0, 0, -1], [0, 0, 0, 0], [1, 1, 1, 1], [1, 0, 0, 3]]
    J[6:12, 1:3] = 0  # diagonal Jacobians: the scaling block may be diagonal too
    a, b, c, d = J.T
    D = a * d - b * c
    h = np.sqrt(eps * eps + D * D)
    ch, d1, d2 = _chi(D, eps), 0.5 + 0.5 * D / h, 0.5 * eps * eps / h ** 3
    N = (1 - THETA) * (J * J).sum(1) + THETA * (1 + D * D)
    ND = 2 * THETA * D
    modes, lam = _modes(J.T, (1 - THETA) / ch, ND / ch - N * d1 / ch ** 2, -(1 - THETA) * d1 / ch ** 2,
                        2 * THETA / ch - 2 * ND * d1 / ch ** 2 - N * d2 / ch ** 2 + 2 * N * d1 ** 2 / ch ** 3)
    for t in range(len(J)):
        H = element_hessian(J[t], eps)
        Q = modes[:, :, t]
        np.testing.assert_allclose(Q.T @ Q, np.eye(4), atol=1e-12)  # orthonormal modes
        scale = np.abs(H).max()
        assert np.abs(Q @ np.diag(lam[:, t]) @ Q.T - H).max() <= 1e-10 * scale
        w, X = np.linalg.eigh(H)
        proj = X @ np.diag(np.maximum(w, 0)) @ X.T
        assert np.abs(Q @ np.diag(np.maximum(lam[:, t], 0)) @ Q.T - proj).max() <= 1e-10 * scale


def test_gradient_and_assembled_hessian():
    V, F = rectangle(6.0, 6.0, 2.0)
    rng = np.random.default_rng(1)
    U = V + rng.normal(scale=1.5, size=V.shape)  # folded here and there
    move = np.arange(2, len(V) - 1)
    en = _Energy(V, F, U, move, len(V), len(F))
    x = U[move].ravel()
    E, g, data = en.newton(x, 0.1)
    assert E == pytest.approx(en.energy(x, 0.1)[0], rel=1e-14)
    h = 1e-6
    fd = np.array([(en.energy(x + h * e, 0.1)[0] - en.energy(x - h * e, 0.1)[0]) / (2 * h)
                   for e in np.eye(len(x))])
    assert np.abs(g - fd).max() <= 1e-6 * np.abs(g).max()
    A = sp.csc_matrix((data, en.indices, en.indptr), shape=(len(x), len(x))).toarray()
    A = A + np.triu(A, 1).T
    assert np.linalg.eigvalsh(A).min() >= -1e-9 * np.abs(A).max()  # projected: PSD


def test_budget_counts_and_caps():
    b = Budget(10.0)
    assert b.affords(10.0) and not b.affords(10.5)
    b.charge(4.0)
    assert b.left == 6.0 and not b.affords(6.5)
    late = Budget(1e9, time_limit=0.0)
    assert not late.affords(0.0) and late.late
    assert cost.newton_cost(1.0, 1.0, 4000) == cost.NEWTON_TRI + cost.NEWTON_SOLVE + cost.NEWTON_FIXED / 4000
    assert default_budget(100) == pytest.approx(50 * default_budget(5000))
    assert default_budget(20000) == default_budget(5000)


@pytest.fixture(scope="module")
def bar():
    V, F = rectangle(100.0, 20.0, 8.0)
    b = nearest(V, [[0, 0], [0, 20], [100, 10]])
    return V, F, b, arap_precompute(V, F, b)


def test_relaxation_stays_within_any_budget_and_is_deterministic(bar):
    V, F, b, d = bar
    bc = np.array([V[b[0]], V[b[1]], [20.0, 10.0]])  # folds; needs the untangling
    U = arap_solve(d, bc)
    n0 = len(folded_triangles(V, U, F))
    assert n0 > 0
    spent = []
    for units in (0.0, 1.0, 15.0, 60.0, 200.0, np.inf):
        info = {}
        R = relax_foldovers(d, U, bc, budget=units, info=info)
        assert info["units"] <= units
        assert np.isfinite(R).all() and np.array_equal(R[b], bc)
        assert info["folds_out"] == len(folded_triangles(V, R, F)) <= n0
        again = relax_foldovers(d, U, bc, budget=units)
        assert np.array_equal(R, again), "same pins, same budget: same shape"
        spent.append((info["units"], info["folds_out"]))
    assert spent[0] == (0.0, n0)  # nothing affordable: the pose as given
    assert spent[-1][1] == 0  # unbounded: fold-free
    assert spent[-1][0] > 15.0  # ... which takes more work than the small budgets allow


def test_untangle_stops_where_its_budget_ends(bar):
    V, F, b, d = bar
    bc = np.array([V[b[0]], V[b[1]], [20.0, 10.0]])
    U = arap_solve(d, bc)
    move = np.setdiff1d(np.arange(len(V)), b)
    meter = Budget(25.0)
    X = untangle(V, F, U, move, budget=meter)
    assert meter.used <= 25.0
    assert np.isfinite(X).all() and np.array_equal(X[b], U[b])
    full = Budget(np.inf)
    untangle(V, F, U, move, budget=full)
    assert full.used > 25.0
