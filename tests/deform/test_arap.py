import numpy as np
import pytest

import puppet.deform.arap as arap_mod
import puppet.deform.factor as factor_mod
from puppet.deform import ArapData, arap_energy, arap_precompute, arap_solve
from puppet.geom.geodesic import geodesic_distances
from puppet.geom.laplacian import cotangent_weights, laplacian_from_weights, uniform_weights
from tests.deform.meshes import l_shape, nearest, rectangle, rot







V_L, F_L = l_shape()
B_L = nearest(V_L, [[1, 1], [19, 1], [1, 19], [19, 7]])


@pytest.mark.parametrize("weights", ["cotangent", "uniform"])
@pytest.mark.parametrize("init", ["mls", "rest"])
def test_rest_targets_give_rest_mesh(weights, init):
    data = arap_precompute(V_L, F_L, B_L, weights=weights)
    U0 = None if init == "mls" else V_L
    U = arap_solve(data, V_L[B_L], iterations=30, U0=U0)
    assert np.abs(U - V_L).max() < 1e-9


@pytest.mark.parametrize("weights", ["cotangent", "uniform"])
def test_pinned_vertices_exactly_at_targets(weights):
    data = arap_precompute(V_L, F_L, B_L, weights=weights)
    bc = V_L[B_L] + np.array([[3.3, -1.7], [0.1, 0.2], [-4.0, 2.5], [1 / 3, 2 / 7]])
    for U0 in (None, V_L + 0.5):
        U = arap_solve(data, bc, iterations=5, U0=U0)
        np.testing.assert_array_equal(U[B_L], bc)


@pytest.mark.parametrize("weights", ["cotangent", "uniform"])
def test_energy_never_increases(weights):
    data = arap_precompute(V_L, F_L, B_L, weights=weights)
    bc = V_L[B_L].copy()
    bc[1] += [-6.0, 9.0]  # bend the horizontal arm up
    bc[2] += [7.0, -2.0]
    for U0 in (None, V_L):
        energies = []
        U0_full = arap_solve(data, bc, iterations=0, U0=U0)
        arap_solve(data, bc, iterations=25, U0=U0,
                   callback=lambda it, U: energies.append(arap_energy(data, U)))
        E = np.r_[arap_energy(data, U0_full), energies]
        assert len(E) == 26
        assert E[-1] > 1e-3  # a real deformation
        assert np.all(np.diff(E) <= 1e-10 * E[0]), np.diff(E).max()
        assert E[-1] < 0.9 * E[0]


@pytest.mark.parametrize("weights", ["cotangent", "uniform"])
def test_rigid_motion_of_pins_moves_whole_mesh_rigidly(weights):
    data = arap_precompute(V_L, F_L, B_L, weights=weights)
    R, t = rot(2.0), np.array([40.0, -15.0])
    U = arap_solve(data, V_L[B_L] @ R.T + t)
    expected = V_L @ R.T + t
    assert np.abs(U - expected).max() < 1e-6 * np.ptp(V_L)
    assert arap_energy(data, U) < 1e-12


def test_hand_checked_energy_of_scaled_square():
    # unit square split in two: boundary weights 1/2, diagonal 0; U = 2V (any rotation)
    V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    data = arap_precompute(V, np.array([[0, 1, 2], [0, 2, 3]]), [0])
    assert arap_energy(data, V) == 0.0
    # 4 edges x 2 cells x w = 1/2 x |2e - e|^2 = 1
    assert arap_energy(data, 2 * V) == pytest.approx(4.0)
    assert arap_energy(data, 2 * V @ rot(0.8).T + 3.0) == pytest.approx(4.0)


def test_stretched_bar_has_positive_energy():
    V, F = rectangle(10.0, 1.0, 0.05)
    left, right = np.flatnonzero(V[:, 0] < 1e-9), np.flatnonzero(V[:, 0] > 10 - 1e-9)
    b = np.r_[left, right]
    data = arap_precompute(V, F, b)
    bc = V[b].copy()
    assert arap_energy(data, arap_solve(data, bc)) < 1e-18
    bc[len(left):, 0] += 5.0
    U = arap_solve(data, bc)
    E = arap_energy(data, U)
    assert E > 0.1
    # the bar really is stretched, roughly uniformly
    mid = np.argmin(np.abs(V[:, 0] - 5.0) + np.abs(V[:, 1] - 0.5))
    assert U[mid, 0] == pytest.approx(7.5, abs=0.3)


def test_unpinned_components_stay_at_rest():
    V1, F1 = rectangle(4.0, 4.0, 0.5)
    V = np.r_[V1, V1 + [10.0, 0.0], [[50.0, 50.0]]]  # + a copy + an isolated vertex
    F = np.r_[F1, F1 + len(V1)]
    b = nearest(V, [[0, 0], [4, 0], [0, 4]])
    data = arap_precompute(V, F, b)
    assert len(data.held) == len(V1) + 1
    bc = V[b] @ rot(0.5).T + [1.0, 2.0]
    bc[0] += [0.5, -0.5]
    U = arap_solve(data, bc)
    np.testing.assert_array_equal(U[len(V1):], V[len(V1):])
    assert np.abs(U[: len(V1)] - V1).max() > 0.5


def test_no_pins_everything_at_rest():
    data = arap_precompute(V_L, F_L, [])
    assert data.factor is None
    np.testing.assert_array_equal(arap_solve(data, np.zeros((0, 2))), V_L)


def test_drag_does_not_refactorise():
    before = factor_mod.FACTORIZATIONS
    data = arap_precompute(V_L, F_L, B_L)
    assert factor_mod.FACTORIZATIONS == before + 1
    factor = data.factor
    for k in range(5):
        bc = V_L[B_L] + [k * 1.0, -k * 0.5]
        arap_solve(data, bc, iterations=3)
    assert factor_mod.FACTORIZATIONS == before + 1
    assert data.factor is factor


def test_trajectory_invariance():
    data = arap_precompute(V_L, F_L, B_L)
    bc1 = V_L[B_L] + [[5.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 3.0]]
    bc2 = V_L[B_L] + [[-2.0, 4.0], [1.0, 0.0], [0.0, -3.0], [0.0, 0.0]]
    fresh = arap_solve(arap_precompute(V_L, F_L, B_L), bc2)
    arap_solve(data, bc1)
    np.testing.assert_array_equal(arap_solve(data, bc2), fresh)


def test_splu_and_fallback_agree_with_cholespy(monkeypatch):
    bc = V_L[B_L] + [[5.0, 2.0], [0.0, 0.0], [-3.0, 0.0], [0.0, 3.0]]
    U_chol = arap_solve(arap_precompute(V_L, F_L, B_L, solver="cholespy"), bc)
    d_lu = arap_precompute(V_L, F_L, B_L, solver="splu")
    assert d_lu.factor.kind == "splu"
    np.testing.assert_allclose(arap_solve(d_lu, bc), U_chol, atol=1e-9)

    class Refuses:
        def __init__(self, A):
            raise ValueError("Matrix is not positive definite!")

    monkeypatch.setattr(factor_mod, "_CholespyFactor", Refuses)
    d_fb = arap_precompute(V_L, F_L, B_L, solver="cholespy")
    assert d_fb.factor.kind == "splu"
    np.testing.assert_allclose(arap_solve(d_fb, bc), U_chol, atol=1e-9)


def test_qdldl_default_agrees_with_cholespy_with_and_without_threads(monkeypatch):
    pytest.importorskip("qdldl")
    bc = V_L[B_L] + [[5.0, 2.0], [0.0, 0.0], [-3.0, 0.0], [0.0, 3.0]]
    U_chol = arap_solve(arap_precompute(V_L, F_L, B_L, solver="cholespy"), bc)
    data = arap_precompute(V_L, F_L, B_L)
    assert data.factor.kind == "qdldl"
    U = arap_solve(data, bc)
    np.testing.assert_allclose(U, U_chol, atol=1e-9)
    monkeypatch.setattr(factor_mod, "PARALLEL_MIN_FREE", 0)  # both coordinates on 2 threads
    np.testing.assert_array_equal(arap_solve(data, bc), U)
    seen = []
    np.testing.assert_array_equal(arap_solve(data, bc, callback=lambda it, Ui: seen.append(Ui)), U)
    assert len(seen) == 20 and np.array_equal(seen[-1], U)
    monkeypatch.setattr(factor_mod, "THREADS", False)  # everything on the caller's thread
    serial = arap_precompute(V_L, F_L, B_L)
    np.testing.assert_array_equal(serial.D, data.D)
    np.testing.assert_array_equal(arap_solve(serial, bc), U)


def test_missing_qdldl_falls_back_to_cholespy(monkeypatch):
    class Missing:
        def __init__(self, A):
            raise ImportError("No module named 'qdldl'")

    monkeypatch.setattr(factor_mod, "_QdldlFactor", Missing)
    assert arap_precompute(V_L, F_L, B_L).factor.kind == "cholespy"


def test_errors_on_the_second_thread_reach_the_caller(monkeypatch):
    def singular(A, solver):
        raise ValueError("ARAP system is singular")

    data = arap_precompute(V_L, F_L, B_L)
    with monkeypatch.context() as m:
        m.setattr(factor_mod, "factorize", singular)
        with pytest.raises(ValueError, match="singular"):
            arap_precompute(V_L, F_L, B_L)

    class Broken(factor_mod._QdldlFactor):
        def __init__(self, good):
            self.__dict__.update(good.__dict__)

        def solve1(self, b):
            raise RuntimeError("broken solve")

    data.factor = Broken(data.factor)
    monkeypatch.setattr(factor_mod, "PARALLEL_MIN_FREE", 0)
    with pytest.raises(RuntimeError, match="broken solve"):
        arap_solve(data, V_L[B_L] + 1.0, iterations=3)


@pytest.mark.parametrize("weights", ["cotangent", "cotangent-raw", "uniform"])
def test_one_pass_build_matches_puppet_geom(weights):
    V1, F1 = rectangle(4.0, 4.0, 0.5)
    V = np.r_[V_L, V1 + [30.0, 0.0]]  # + a component without pins: D = inf there
    F = np.r_[F_L, F1 + len(V_L)]
    data = arap_precompute(V, F, B_L, weights=weights)
    W = uniform_weights(V, F) if weights == "uniform" else cotangent_weights(V, F)
    if weights == "cotangent":
        W.data = np.maximum(W.data, 0.0)  # ARAP clamps negative cotangent weights
    W.eliminate_zeros()
    assert abs(data.W - W).max() < 1e-12
    assert abs(data.L - laplacian_from_weights(W)).max() < 1e-12
    np.testing.assert_allclose(data.D, geodesic_distances(V, F, B_L), rtol=1e-12)
    assert np.isinf(data.D[:, len(V_L):]).all()


@pytest.mark.parametrize("weights", ["cotangent", "uniform"])
def test_real_operators_C_K_match_the_complex_ones(weights):
    # C and K (the real forms, built on first access) against S and R of the solver
    data = arap_precompute(V_L, F_L, B_L, weights=weights)
    n = data.n
    U = V_L @ rot(0.3).T + np.random.default_rng(1).normal(scale=0.5, size=V_L.shape)
    q = data.S0 + data.S @ ((U - V_L) @ np.array([1.0, 1.0j]))
    CU = data.C @ U
    assert data.C.shape == (2 * n, n)
    np.testing.assert_allclose(CU[:n, 0] + CU[n:, 1], q.real, atol=1e-9)
    np.testing.assert_allclose(CU[:n, 1] - CU[n:, 0], q.imag, atol=1e-9)
    cm1, s = arap_mod._rotations(data, U)
    Z = np.r_[np.c_[cm1, s], np.c_[-s, cm1]]
    rhs = data.R @ (cm1 + 1j * s)
    assert data.K.shape == (len(data.free), 2 * n)
    np.testing.assert_allclose(data.K @ Z, np.c_[rhs.real, rhs.imag], atol=1e-9)
    np.testing.assert_allclose(np.hypot(cm1 + 1, s), 1.0)


def test_bad_input_raises():
    with pytest.raises(ValueError):
        arap_precompute(V_L, F_L, [0, 0])
    with pytest.raises(ValueError):
        arap_precompute(V_L, F_L, [len(V_L)])
    with pytest.raises(ValueError):
        arap_precompute(V_L, F_L, B_L, weights="harmonic")
    data = arap_precompute(V_L, F_L, B_L)
    assert isinstance(data, ArapData)
    with pytest.raises(ValueError):
        arap_solve(data, np.zeros((3, 2)))


# ---- independent dense reference (loops, SVD rotations, direct solve for U) ----------

def reference_arap(V, F, b, bc, U, iterations):
    n = len(V)
    W = np.zeros((n, n))
    for tri in F:
        for c in range(3):
            o, i, j = tri[c], tri[(c + 1) % 3], tri[(c + 2) % 3]
            e1, e2 = V[i] - V[o], V[j] - V[o]
            cot = np.dot(e1, e2) / abs(e1[0] * e2[1] - e1[1] * e2[0])
            W[i, j] += cot / 2
            W[j, i] += cot / 2
    W = np.maximum(W, 0.0)  # as puppet's ARAP: negative cotangent weights clamped
    L = np.diag(W.sum(1)) - W
    free = np.setdiff1d(np.arange(n), b)
    U = U.copy()
    U[b] = bc
    for _ in range(iterations):
        R = np.zeros((n, 2, 2))
        for i in range(n):
            S = np.zeros((2, 2))
            for j in np.flatnonzero(W[i]):
                S += W[i, j] * np.outer(V[i] - V[j], U[i] - U[j])
            u, _, vt = np.linalg.svd(S)
            Ri = vt.T @ u.T
            if np.linalg.det(Ri) < 0:
                vt[1] *= -1
                Ri = vt.T @ u.T
            R[i] = Ri
        rhs = np.zeros((n, 2))
        for i in range(n):
            for j in np.flatnonzero(W[i]):
                rhs[i] += W[i, j] / 2 * (R[i] + R[j]) @ (V[i] - V[j])
        rhs_f = rhs[free] - L[np.ix_(free, b)] @ bc
        U[free] = np.linalg.solve(L[np.ix_(free, free)], rhs_f)
    return U


def test_matches_dense_reference():
    V, F = rectangle(6.0, 3.0, 0.6)
    b = nearest(V, [[0, 0], [6, 0], [6, 3]])
    bc = V[b] + [[0.0, 0.0], [1.5, 2.0], [-1.0, 3.0]]
    data = arap_precompute(V, F, b)
    U0 = arap_solve(data, bc, iterations=0)
    U = arap_solve(data, bc, iterations=8, U0=U0)
    Uref = reference_arap(V, F, b, bc, U0, 8)
    assert np.abs(U - Uref).max() < 1e-9
    assert np.abs(U - U0).max() > 0.05  # the iterations did something


def test_negative_cotangent_weights_do_not_flip_cells_at_rest():
    """A poor (non-Delaunay-quality) mesh has negative cotangent weights; a cell whose
    weights summed negative used to fit a 180-degree rotation at rest."""
    import triangle as tr
    t = np.linspace(0, np.pi, 40)
    outline = np.c_[np.r_[np.cos(t) * 60, np.cos(t[::-1]) * 58], np.r_[np.sin(t) * 60, np.sin(t[::-1]) * 58 - 2]]
    n = len(outline)
    T = tr.triangulate({"vertices": outline, "segments": np.c_[np.arange(n), (np.arange(n) + 1) % n]}, "p")
    V, F = T["vertices"], T["triangles"].astype(np.int64)
    raw = cotangent_weights(V, F)
    assert (raw.data < 0).any(), "the test mesh has negative cotangent weights"
    b = nearest(V, [[60, 0], [-60, 0], [0, 60]])
    data = arap_precompute(V, F, b)
    assert (data.W.data >= 0).all() and (data.S0 > 0).all()
    U = arap_solve(data, V[b])
    assert np.abs(U - V).max() < 1e-9


def _obtuse_mesh():
    """A rectangle stretched after meshing: non-Delaunay, with negative cotangent weights."""
    V, F = rectangle(20.0, 20.0, 1.0)
    return V * [1.6, 0.6], F


def test_raw_cotangent_weights_keep_negative_weights():
    V, F = _obtuse_mesh()
    b = nearest(V, [[1, 1], [31, 1], [16, 11]])
    raw = arap_precompute(V, F, b, weights="cotangent-raw")
    clamped = arap_precompute(V, F, b, weights="cotangent")
    assert (raw.W.data < 0).sum() > 10
    assert (clamped.W.data >= 0).all()
    bc = V[b] + [[0, 0], [4, -6], [-3, 5]]
    np.testing.assert_array_equal(arap_solve(raw, bc)[b], bc)
    # rest pins: the clamped weights give the rest mesh back; raw ones need not (a cell
    # whose weights sum negative fits a half turn at rest, as in libigl)
    assert np.abs(arap_solve(clamped, V[b]) - V).max() < 1e-9
    with pytest.raises(ValueError, match="weights"):
        arap_precompute(V, F, b, weights="cot")


def test_raw_cotangent_weights_equal_libigl():
    igl = pytest.importorskip("igl")
    V, F = _obtuse_mesh()
    b = nearest(V, [[1, 1], [31, 1], [16, 11], [5, 10]])
    bc = V[b] + [[0, 0], [4, -6], [-3, 5], [2, 2]]
    raw = arap_precompute(V, F, b, weights="cotangent-raw")
    U0 = arap_solve(raw, bc, iterations=0)
    ref = igl.ARAPData()
    ref.energy = igl.ARAPEnergyType.ARAP_ENERGY_TYPE_SPOKES
    ref.max_iter = 30
    igl.arap_precomputation(V, F.astype(np.int64), 2, b.astype(np.int32), ref)
    U_igl = igl.arap_solve(bc, ref, U0)
    assert np.abs(arap_solve(raw, bc, iterations=30, U0=U0) - U_igl).max() <= 1e-6
    clamped = arap_precompute(V, F, b, weights="cotangent")
    assert np.abs(arap_solve(clamped, bc, iterations=30, U0=U0) - U_igl).max() > 1e-3
