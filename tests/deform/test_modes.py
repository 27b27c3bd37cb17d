"""Deformation modes, cell weights, springs and the hinge guess: hand-checked cases and
identities (puppet.deform.modes, puppet.deform.hinge, arap_precompute's new options)."""
import numpy as np
import pytest

from puppet.deform.arap import arap_precompute, arap_solve
from puppet.deform.hinge import hinge_guess
from puppet.deform.modes import (MODES, apply_similarity, cell_sigma, mode_mix, similarity_fit,
                                 stiffness_from_grey)
from tests.deform.meshes import nearest, rectangle, rot, two_squares


def test_similarity_fit_by_hand():
    s, t = similarity_fit([[0, 0], [1, 0]], [[0, 0], [0, 2]])
    assert s == pytest.approx(2j) and t == pytest.approx(0)  # turn 90 degrees, scale 2
    s, t = similarity_fit([[1, 1]], [[4, 5]])
    assert s == 1 and t == pytest.approx(3 + 4j)  # one point: a shift
    P = np.array([[0, 0], [3, 1], [-2, 5.0]])
    Q = apply_similarity(P, 0.5 - 0.2j, 7 + 1j)
    s, t = similarity_fit(P, Q)
    assert s == pytest.approx(0.5 - 0.2j) and t == pytest.approx(7 + 1j)


def test_cell_fits_by_hand():
    # one cell with spokes e = 1, i, -1 - i (unit weights)
    e = np.array([1, 1j, -1 - 1j])
    S0 = np.array([np.sum(np.abs(e) ** 2)])
    G = np.array([np.sum(e * e)])
    for a, b in [(2.0, 0.0), (1j, 0.0), (1.0, 0.5), (0.3 + 0.1j, -0.2j)]:
        u = a * e + b * e.conj()
        q = np.array([np.sum(e.conj() * u)])
        p = np.array([np.sum(e * u)])
        sig, beta = cell_sigma(mode_mix(["distort"]), q, p, S0, G)
        # distort = half rotation + half affine; with mix (0, 0, 1) the affine alone comes back
        sig_a, beta_a = cell_sigma(np.array([[0.0, 0.0, 1.0]]), q, p, S0, G)
        assert sig_a[0] == pytest.approx(a - 1) and beta_a[0] == pytest.approx(b)
        sig_s, _ = cell_sigma(mode_mix(["similar"]), q, p, S0, G)
        if b == 0:
            assert sig_s[0] == pytest.approx(a - 1)
            sig_r, _ = cell_sigma(mode_mix(["rigid"]), q, p, S0, G)
            assert sig_r[0] == pytest.approx(a / abs(a) - 1)


def test_mode_mix_and_stiffness_mapping():
    mix = mode_mix(["rigid", "similar", "distort"], stiff=[0.0, 1.0, 0.5])
    assert np.allclose(mix, [[1, 0, 0], [1, 0, 0], [0.75, 0, 0.25]])
    assert np.allclose(mix.sum(1), 1)
    assert stiffness_from_grey([0, 255]) == pytest.approx([1, 100])
    assert stiffness_from_grey(127.5) == pytest.approx(10)


def bar():
    V, F = rectangle(40, 8, 1.5)
    b = nearest(V, [[0, 4], [40, 4]])
    return V, F, b


@pytest.mark.parametrize("mode", MODES)
def test_identities_in_every_mode(mode):
    V, F, b = bar()
    d = arap_precompute(V, F, b, mix=mode_mix([mode] * len(V)))
    assert np.abs(arap_solve(d, V[b]) - V).max() < 1e-9  # rest pins: rest mesh
    R = rot(0.7)
    U = arap_solve(d, V[b] @ R.T + [3, -2])
    assert np.abs(U - (V @ R.T + [3, -2])).max() < 1e-6  # a rigid motion of the pins
    assert np.array_equal(U[b], V[b] @ R.T + [3, -2])


def test_similar_scales_exactly_from_the_similarity_guess():
    V, F, b = bar()
    d = arap_precompute(V, F, b, mix=mode_mix(["similar"] * len(V)))
    c = V[b].mean(0)
    bc = c + 0.6 * (V[b] - c)
    s, t = similarity_fit(V[b], bc)
    U = arap_solve(d, bc, U0=apply_similarity(V, s, t))
    assert np.abs(U - (c + 0.6 * (V - c))).max() < 1e-9
    # from the plain MLS guess it heads for the same shape (slowly: a low-frequency mode)
    err = [np.abs(arap_solve(d, bc, iterations=it) - U).max() for it in (20, 200)]
    assert err[1] < 0.5 * err[0] and err[1] < 0.2


def test_rigid_mix_is_plain_arap_and_uniform_stiffness_changes_nothing():
    V, F, b = bar()
    bc = V[b] + [[0, 0], [-5, 9]]
    plain = arap_solve(arap_precompute(V, F, b), bc)
    mixed = arap_solve(arap_precompute(V, F, b, mix=mode_mix(["rigid"] * len(V))), bc)
    assert np.abs(mixed - plain).max() < 1e-9
    scaled = arap_solve(arap_precompute(V, F, b, stiffness=np.full(len(V), 7.0)), bc)
    assert np.abs(scaled - plain).max() < 1e-9


def test_stiff_cells_bend_less():
    V, F, b = bar()
    bc = V[b] + [[0, 0], [-6, 12]]
    k = np.where(np.abs(V[:, 0] - 20) < 6, 100.0, 1.0)
    d0, d1 = arap_precompute(V, F, b), arap_precompute(V, F, b, stiffness=k)
    U0, U1 = arap_solve(d0, bc), arap_solve(d1, bc)
    mid = np.abs(V[:, 0] - 20) < 5
    e0 = _cell_strain(V, F, U0, mid)
    e1 = _cell_strain(V, F, U1, mid)
    assert e1 < 0.25 * e0


def _cell_strain(V, F, U, sel):
    keep = sel[F].all(1)
    a, b = V[F[keep, 1]] - V[F[keep, 0]], V[F[keep, 2]] - V[F[keep, 0]]
    c, d = U[F[keep, 1]] - U[F[keep, 0]], U[F[keep, 2]] - U[F[keep, 0]]
    J = np.stack([c, d], 2) @ np.linalg.inv(np.stack([a, b], 2))
    return float(((np.linalg.svd(J, compute_uv=False) - 1) ** 2).sum())


def test_springs_join_two_sheets():
    V1, F1 = rectangle(10, 4, 1.0)
    V = np.vstack([V1, V1 + [10, 0]])
    F = np.vstack([F1, F1 + len(V1)])
    right = np.flatnonzero(np.isclose(V1[:, 0], 10))
    left = len(V1) + np.flatnonzero(np.isclose(V1[:, 0], 0))
    pairs = np.array([(i, j) for i in right for j in left if np.allclose(V[i], V[j])])
    assert len(pairs) >= 3
    b = nearest(V, [[0, 2], [20, 2]])
    bc = V[b] + [[0, 0], [0, 6]]
    gaps = []
    for kappa in (0.1, 1e4):
        d = arap_precompute(V, F, b, couple=(pairs, kappa))
        assert len(d.held) == 0  # the springs connect the two sheets
        assert np.abs(arap_solve(d, V[b]) - V).max() < 1e-9
        U = arap_solve(d, bc)
        gaps.append(np.linalg.norm(U[pairs[:, 0]] - U[pairs[:, 1]], axis=1).max())
    assert gaps[1] < 1e-2 < gaps[0]


def test_hinge_guess_turns_a_part_about_its_hinge():
    # two squares side by side sharing the vertex (10, 0) only through distances
    V = np.array([[0, 0], [10, 0], [0, 10], [20, 0], [20, 10.0]])
    parts = [np.array([0, 1, 2]), np.array([1, 3, 4])]
    P = V[[0, 2, 3]]
    bc = np.array([[0, 0], [0, 10], [10, -10.0]])  # the second part's pin turned -90 degrees about (10, 0)
    D = np.linalg.norm(V[None] - P[:, None], axis=2)
    DH = np.linalg.norm(V[None] - V[[1]][:, None], axis=2)[:, None].repeat(2, axis=1)  # (1, 2, n)
    U = hinge_guess(V, D, P, bc, np.array([0, 0, 1]), parts, np.array([[1, 1]]), DH)
    assert np.allclose(U[1], [10, 0])  # the two-pin part decides where the hinge is
    assert np.allclose(U[[0, 2, 3]], bc)
    assert np.allclose(U[4], [20, -10])  # rigidly turned about the hinge


@pytest.mark.parametrize("mode", MODES)
def test_folded_constants_match_the_cell_fits(mode):
    V, F, b = bar()
    grey = np.linspace(0, 255, len(V))
    d = arap_precompute(V, F, b, mix=mode_mix([mode] * len(V), grey / 255))
    rng = np.random.default_rng(1)
    U = V + rng.normal(scale=0.5, size=V.shape)
    x = (U - V) @ [1, 1j]
    q = d.S0 + d.S @ x
    p = d.modes.G + (d.modes.T_f @ x[d.free] + d.modes.T_b @ x[d.b] if d.modes.affine else 0)
    want = cell_sigma(d.mix, q.copy(), p, d.S0, d.modes.G)
    got = d.modes.sigma(q.copy(), p if d.modes.affine else None)
    assert np.allclose(got[0], want[0])
    assert (got[1] is None) == (want[1] is None) or np.allclose(want[1], 0)
    if got[1] is not None:
        assert np.allclose(got[1], want[1])


def test_hinge_guess_with_two_vertices_at_the_hinge():
    # the same as above, but the hinge is two vertices (a link of strength < 1)
    V, parts, P, bc, D, DH = two_squares()
    U = hinge_guess(V, D, P, bc, np.array([0, 0, 1]), parts, np.array([[1, 5]]), DH)
    assert np.allclose(U[[1, 5]], [[10, 0], [10, 0]])
    assert np.allclose(U[4], [20, -10])


def test_folds_of_a_mode_are_untangled_without_making_cells_rigid():
    from puppet.deform.relax import folded_triangles, relax_foldovers

    V, F = rectangle(40, 8, 1.0)
    b = nearest(V, [[0, 4], [40, 4], [20, 4]])
    bc = V[b] + [[0, 0], [-38, 0], [0, -10]]  # the right end pulled back over the bar
    d = arap_precompute(V, F, b, mix=mode_mix(["distort"] * len(V)))
    U = arap_solve(d, bc)
    assert len(folded_triangles(V, U, F)) > 0
    info = {}
    U2 = relax_foldovers(d, U, bc, info=info)
    assert info["stage"] == "untangle"  # the similarity stage (rigid cells) is skipped
    assert len(folded_triangles(V, U2, F)) == 0
    assert np.array_equal(U2[b], bc)


def test_similar_scale_bounds_by_hand():
    V, F, b = bar()
    d = arap_precompute(V, F, b, mix=mode_mix(["similar"] * len(V)))
    c = V.mean(0)
    for f, want in ((2.0, 1.25), (0.5, 0.8), (1.1, 1.1)):
        x = (f - 1.0) * ((V - c) @ [1, 1j])  # every cell scaled by f about the centre
        q = d.S0 + d.S @ x
        sigma, _ = d.modes.sigma(q, None, (0.8, 1.25))
        inner = np.flatnonzero(d.S0 > 0)
        assert np.allclose(sigma[inner], want - 1.0)  # clamped to [0.8, 1.25], no turn
        free_sigma, _ = d.modes.sigma(q, None)
        assert np.allclose(free_sigma[inner], f - 1.0)
