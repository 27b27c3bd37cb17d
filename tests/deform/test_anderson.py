"""Anderson-accelerated ARAP (puppet.deform.anderson): the energy it reports, the plain
loop it wraps, convergence to the same pose, and its refusals."""
import numpy as np
import pytest

from puppet.deform import factor
from puppet.deform.anderson import _local_step, arap_solve_anderson
from puppet.deform.arap import arap_energy, arap_precompute, arap_solve
from puppet.deform.mls import mls_object_space
from tests.deform.meshes import nearest, rectangle


def bent_grid():
    V, F = rectangle(24, 8, 1.0)
    b = nearest(V, [[0, 0], [0, 8], [24, 0], [24, 8]])  # the four corners
    bc = V[b].copy()
    bc[2:] += [[-6.0, 9.0], [-6.0, 9.0]]  # lift the right end
    return V, F, b, bc


def test_energy_is_the_arap_energy_and_zero_at_rest():
    V, F, b, bc = bent_grid()
    a = arap_precompute(V, F, b)
    U = mls_object_space(V, a.D, bc, V[b])
    X = U - V
    xf = X[a.free, 0] + 1j * X[a.free, 1]
    xb = X[b, 0] + 1j * X[b, 1]
    _, e = _local_step(a, xb)(xf)
    assert e == pytest.approx(arap_energy(a, U), rel=1e-10)
    _, e0 = _local_step(a, np.zeros(len(b), complex))(np.zeros(len(a.free), complex))
    assert e0 == 0.0


def test_energy_with_painted_stiffness_weighs_each_cell():
    V, F, b, bc = bent_grid()
    k = 1.0 + (V[:, 0] > 10) * 3.0
    a = arap_precompute(V, F, b, stiffness=k)
    U = mls_object_space(V, a.D, bc, V[b])
    X = U - V
    _, e = _local_step(a, X[b, 0] + 1j * X[b, 1])(X[a.free, 0] + 1j * X[a.free, 1])
    # by hand: sum_i k_i sum_j w_ij |u_ij - R_i e_ij|^2 with each cell's best rotation
    z, u = V[:, 0] + 1j * V[:, 1], U[:, 0] + 1j * U[:, 1]
    ei, ej, w = a.ei, a.ej, a.ew
    m = w * np.conj(z[ei] - z[ej]) * (u[ei] - u[ej])
    q = np.bincount(ei, m.real, minlength=len(V)) + 1j * np.bincount(ei, m.imag, minlength=len(V))
    rho = q / np.abs(q)
    cell = np.bincount(ei, w * np.abs((u[ei] - u[ej]) - rho[ei] * (z[ei] - z[ej])) ** 2, minlength=len(V))
    assert e == pytest.approx(float(k @ cell), rel=1e-10)


def test_window_zero_is_the_plain_loop_bit_for_bit():
    V, F, b, bc = bent_grid()
    a = arap_precompute(V, F, b)
    U, info = arap_solve_anderson(a, bc, iterations=12, tolerance=1e-12, window=0)
    assert info.iterations == 12 and info.rejected == 0
    assert np.array_equal(U, arap_solve(a, bc, iterations=12))


def test_converges_to_the_plain_loops_pose_with_fewer_iterations_and_never_raises_the_energy():
    V, F, b, bc = bent_grid()
    a = arap_precompute(V, F, b)
    before = factor.FACTORIZATIONS
    U, info = arap_solve_anderson(a, bc, iterations=500, tolerance=1e-4)
    assert factor.FACTORIZATIONS == before  # the factor is reused, never rebuilt
    assert info.converged
    assert np.all(np.diff(info.energies) <= 0)
    assert arap_energy(a, U) <= info.energies[-1] * (1 + 1e-12)
    plain = arap_solve(a, bc, iterations=5000)
    assert np.abs(U - plain).max() < 1e-2
    _, slow = arap_solve_anderson(a, bc, iterations=5000, tolerance=1e-4, window=0)
    assert slow.converged and info.iterations * 2 < slow.iterations
    assert np.array_equal(U[b], bc)


def test_rest_pins_give_the_rest_mesh_at_once():
    V, F, b, _ = bent_grid()
    a = arap_precompute(V, F, b)
    U, info = arap_solve_anderson(a, V[b], iterations=50)
    assert np.array_equal(U, V) and info.converged and info.iterations == 1


def test_refuses_modes_and_bad_tolerances():
    V, F, b, bc = bent_grid()
    a = arap_precompute(V, F, b, mix=np.tile([0.0, 1.0, 0.0], (len(V), 1)))
    with pytest.raises(ValueError, match="rigid loop"):
        arap_solve_anderson(a, bc)
    with pytest.raises(ValueError, match="tolerance must be > 0"):
        arap_solve_anderson(arap_precompute(V, F, b), bc, tolerance=0)
