import numpy as np
import pytest

from puppet.deform.mls import KINDS, mls_deform, mls_object_space

rng = np.random.default_rng(0)
P = np.array([[0.0, 0.0], [10.0, 1.0], [3.0, 8.0], [-4.0, 5.0], [6.0, -6.0]])
X = rng.uniform(-12, 14, size=(500, 2))


def rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


@pytest.mark.parametrize("kind", KINDS)
def test_interpolates_control_points_exactly(kind):
    q = P + rng.normal(size=P.shape) * 3
    Xp = np.r_[X[:20], P, X[20:40]]
    U = mls_deform(Xp, P, q, kind=kind)
    assert np.isfinite(U).all()
    np.testing.assert_array_equal(U[20:25], q)


@pytest.mark.parametrize("kind", KINDS)
def test_identity_when_targets_equal_rest(kind):
    U = mls_deform(X, P, P.copy(), kind=kind)
    np.testing.assert_allclose(U, X, atol=1e-11)


@pytest.mark.parametrize("kind", ["rigid", "similarity"])
def test_identity_is_exact_for_rigid_and_similarity(kind):
    np.testing.assert_array_equal(mls_deform(X, P, P.copy(), kind=kind), X)


@pytest.mark.parametrize("kind", KINDS)
def test_rigid_motion_of_all_controls_moves_every_point_rigidly(kind):
    R, t = rot(1.1), np.array([7.0, -3.0])
    U = mls_deform(X, P, P @ R.T + t, kind=kind)
    np.testing.assert_allclose(U, X @ R.T + t, rtol=0, atol=1e-9)


@pytest.mark.parametrize("kind", ["similarity", "affine"])
def test_uniform_scale_for_similarity(kind):
    A, t = 2.5 * rot(-0.4), np.array([1.0, 2.0])
    U = mls_deform(X, P, P @ A.T + t, kind=kind)
    np.testing.assert_allclose(U, X @ A.T + t, atol=1e-9)


def test_rigid_does_not_reproduce_a_scale():
    U = mls_deform(X, P, 2.0 * P, kind="rigid")
    assert np.abs(U - 2.0 * X).max() > 1.0


def test_affine_map_for_affine():
    A, t = np.array([[1.5, 0.7], [-0.2, 0.8]]), np.array([3.0, -1.0])
    U = mls_deform(X, P, P @ A.T + t, kind="affine")
    np.testing.assert_allclose(U, X @ A.T + t, atol=1e-9)
    U_sim = mls_deform(X, P, P @ A.T + t, kind="similarity")
    assert np.abs(U_sim - (X @ A.T + t)).max() > 0.1


@pytest.mark.parametrize("kind", KINDS)
def test_one_control_point_is_translation(kind):
    p, q = np.array([[2.0, 3.0]]), np.array([[-1.0, 7.0]])
    U = mls_deform(np.r_[X, p], p, q, kind=kind)
    np.testing.assert_allclose(U[:-1], X + (q - p), atol=1e-12)
    np.testing.assert_array_equal(U[-1], q[0])


def test_two_controls_similarity_by_hand():
    # two points fix a similarity exactly: a 90 deg rotation about the origin
    p = np.array([[0.0, 0.0], [2.0, 0.0]])
    q = np.array([[0.0, 0.0], [0.0, 2.0]])
    U = mls_deform(np.array([[1.0, 1.0], [3.0, -2.0]]), p, q, kind="similarity")
    np.testing.assert_allclose(U, [[-1.0, 1.0], [2.0, 3.0]], atol=1e-12)


def test_rigid_stretch_by_hand():
    # p = (-1,0),(1,0) stretched to (-2,0),(2,0); at x = (0.5, 0): w = 1/1.5^2, 1/0.5^2,
    # p* = 0.8, q* = 1.6, best rotation = identity -> f(x) = x - p* + q* = 1.3
    p = np.array([[-1.0, 0.0], [1.0, 0.0]])
    U = mls_deform(np.array([[0.5, 0.0], [0.0, 1.0]]), p, 2 * p, kind="rigid")
    np.testing.assert_allclose(U, [[1.3, 0.0], [0.0, 1.0]], atol=1e-12)


def test_alpha_changes_locality():
    q = P.copy()
    q[0] += [5.0, 0.0]
    x = np.array([[1.0, 1.0]])
    u1 = mls_deform(x, P, q, kind="rigid", alpha=1.0)
    u2 = mls_deform(x, P, q, kind="rigid", alpha=2.0)
    assert abs(u2[0, 0] - u1[0, 0]) > 1e-3


def test_no_controls_and_bad_kind():
    np.testing.assert_array_equal(mls_deform(X, np.zeros((0, 2)), np.zeros((0, 2))), X)
    with pytest.raises(ValueError):
        mls_deform(X, P, P, kind="bogus")


# ---- object space -------------------------------------------------------------

def euclid(p, V):
    return np.linalg.norm(p[:, None, :] - V[None, :, :], axis=2)


@pytest.mark.parametrize("kind", KINDS)
def test_object_space_with_euclidean_distances_equals_image_space(kind):
    q = P + rng.normal(size=P.shape)
    U1 = mls_object_space(X, euclid(P, X), q, P, kind=kind)
    U2 = mls_deform(X, P, q, kind=kind)
    np.testing.assert_allclose(U1, U2, atol=1e-12)


def test_object_space_zero_distance_maps_exactly_to_target():
    q = P + 1.5
    D = euclid(P, X) + 1.0
    D[3, 17] = 0.0
    U = mls_object_space(X, D, q, P, kind="rigid")
    np.testing.assert_array_equal(U[17], q[3])


def test_object_space_unreachable_vertex_stays_and_partial_inf_drops_control():
    q = P @ rot(0.3).T + [1.0, 2.0]
    q[4] += [50.0, 50.0]  # a wild target for a control we will make unreachable
    D = euclid(P, X)
    D[:, 5] = np.inf
    D[4, :] = np.inf
    U = mls_object_space(X, D, q, P, kind="similarity")
    np.testing.assert_array_equal(U[5], X[5])
    keep = np.arange(len(X)) != 5
    ref = mls_object_space(X[keep], euclid(P[:4], X[keep]), q[:4], P[:4], kind="similarity")
    np.testing.assert_allclose(U[keep], ref, atol=1e-12)
    assert np.isfinite(U).all()


def test_object_space_needs_p():
    with pytest.raises(ValueError):
        mls_object_space(X, euclid(P, X), P)
    with pytest.raises(ValueError):
        mls_object_space(X, euclid(P, X)[:, :3], P, P)


def test_image_space_chunks_and_threads_match_one_pass():
    """Large inputs go through cache-sized chunks on threads: same result as one block,
    exact hits on control points included."""
    import puppet.deform.mls as mls
    rng = np.random.default_rng(3)
    p = rng.uniform(0, 100, (7, 2))
    q = p + rng.normal(0, 5, (7, 2))
    X = rng.uniform(0, 100, (2 * mls.CHUNK + 1234, 2))
    X[5] = p[2]
    X[mls.CHUNK + 7] = p[4]
    for kind in ("rigid", "similarity", "affine"):
        U = mls.mls_deform(X, p, q, kind=kind)
        one = mls._mls_image_chunk(X, p, q, kind, 1.0)
        assert np.array_equal(U, one)
        assert np.array_equal(U[5], q[2]) and np.array_equal(U[mls.CHUNK + 7], q[4])
