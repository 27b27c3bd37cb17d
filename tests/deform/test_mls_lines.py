import numpy as np
import pytest
from scipy.integrate import quad

from puppet.deform.mls import KINDS, mls_deform
from puppet.deform.mls_lines import mls_deform_lines, segment_weights

rng = np.random.default_rng(7)
P = np.array([[[0.0, 0.0], [10.0, 2.0]], [[3.0, 8.0], [-4.0, 5.0]], [[12.0, -6.0], [15.0, 3.0]]])
Q = P + rng.normal(size=P.shape) * 2
X = rng.uniform(-20, 25, size=(800, 2))


def rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def along(seg, t, offset=0.0):
    """Points at parameters t on seg, pushed by offset * length along its normal."""
    a, b = seg
    e = b - a
    return a + t[:, None] * e + offset * np.array([-e[1], e[0]])


# ---- the weights --------------------------------------------------------------------

def test_weights_by_hand():
    # a = (-1,0), b = (1,0), x = (0,1): w(t) = 2 / (4 (t - 1/2)^2 + 1); with u = 2t - 1,
    # int w = pi/2, int w 4t(1-t) = int (1-u^2)/(1+u^2) du = pi - 2, ends (pi/2-(pi-2))/2
    W = segment_weights(np.array([[0.0, 1.0]]), np.array([[[-1.0, 0.0], [1.0, 0.0]]]))
    ref = np.array([1 - np.pi / 4, np.pi - 2, 1 - np.pi / 4]) / (np.pi / 2)
    np.testing.assert_allclose(W[0, :, 0], ref, rtol=1e-14)


def quad_reference(x, seg, alpha):
    a, b = seg
    L = np.linalg.norm(b - a)
    tp = np.clip((x - a) @ (b - a) / L**2, 0, 1)
    basis = (lambda t: (1 - t) * (1 - 2 * t), lambda t: 4 * t * (1 - t), lambda t: t * (2 * t - 1))
    out = []
    for lj in basis:
        f = lambda t: L * lj(t) / np.linalg.norm((1 - t) * a + t * b - x) ** (2 * alpha)
        out.append(sum(quad(f, lo, hi, epsabs=0, epsrel=1e-12, limit=200)[0]
                       for lo, hi in ((0, tp), (tp, 1)) if hi > lo))
    return np.array(out)


@pytest.mark.parametrize("alpha", [1.0, 0.7, 1.5])
def test_weights_match_adaptive_quadrature(alpha):
    # near (closed form), far (Gauss-Legendre), beside and beyond the ends
    pts = np.r_[X[:40], along(P[0], np.array([0.3, 0.5, 1.2, -0.4]), 1e-3),
                along(P[0], np.array([1.3, -2.0]), 0.0)]
    W = segment_weights(pts, P, alpha=alpha)
    for n, x in enumerate(pts):
        ref = np.array([quad_reference(x, seg, alpha) for seg in P])
        np.testing.assert_allclose(W[:, :, n], ref / ref.sum(), rtol=0, atol=1e-11)


def test_closed_form_agrees_with_quadrature_path_very_near():
    # alpha = 1 + 1e-13 takes the quadrature path, which must give the same integrals
    pts = np.r_[X, along(P[1], np.linspace(-0.5, 1.5, 41), 1e-7),
                along(P[1], np.linspace(-0.5, 1.5, 41), -3e-5)]
    W1 = segment_weights(pts, P, alpha=1.0)
    W2 = segment_weights(pts, P, alpha=1.0 + 1e-13)
    np.testing.assert_allclose(W1, W2, rtol=0, atol=1e-10)


# ---- the deformation ----------------------------------------------------------------

@pytest.mark.parametrize("kind", KINDS)
def test_points_on_a_segment_map_onto_its_deformed_segment(kind):
    t = np.linspace(0, 1, 11)
    for i in range(len(P)):
        target = (1 - t[:, None]) * Q[i, 0] + t[:, None] * Q[i, 1]
        np.testing.assert_allclose(mls_deform_lines(along(P[i], t), P, Q, kind=kind),
                                   target, rtol=0, atol=1e-12)
        # off the segment by eps * length, the image is within a few eps * length of the
        # target (the offset itself, carried by the local map) and converges linearly
        L = np.linalg.norm(P[i, 1] - P[i, 0])
        err = [np.abs(mls_deform_lines(along(P[i], t, eps), P, Q, kind=kind) - target).max()
               for eps in (1e-6, 1e-9)]
        assert err[0] < 10 * 1e-6 * L
        assert err[1] < err[0] / 100


@pytest.mark.parametrize("kind", KINDS)
def test_identity_when_segments_do_not_move(kind):
    U = mls_deform_lines(X, P, P.copy(), kind=kind)
    if kind == "affine":
        np.testing.assert_allclose(U, X, rtol=0, atol=1e-11)
    else:
        np.testing.assert_array_equal(U, X)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("alpha", [1.0, 1.5])
def test_rigid_motion_of_all_segments_is_that_motion(kind, alpha):
    R, t = rot(1.1), np.array([7.0, -3.0])
    U = mls_deform_lines(X, P, P @ R.T + t, kind=kind, alpha=alpha)
    np.testing.assert_allclose(U, X @ R.T + t, rtol=0, atol=1e-9)


@pytest.mark.parametrize("kind", ["similarity", "affine"])
def test_similarity_for_similarity_and_affine_for_affine(kind):
    A = 1.7 * rot(-0.5) if kind == "similarity" else np.array([[1.5, 0.7], [-0.2, 0.8]])
    t = np.array([2.0, 1.0])
    np.testing.assert_allclose(mls_deform_lines(X, P, P @ A.T + t, kind=kind), X @ A.T + t,
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize("kind", KINDS)
def test_one_segment_translated_is_a_translation(kind):
    seg, t = P[:1], np.array([-4.0, 9.0])
    U = mls_deform_lines(X, seg, seg + t, kind=kind)
    np.testing.assert_allclose(U, X + t, rtol=0, atol=1e-11)


def test_rigid_does_not_reproduce_a_stretch():
    assert np.abs(mls_deform_lines(X, P, 2 * P, kind="rigid") - 2 * X).max() > 1.0


@pytest.mark.parametrize("kind", KINDS)
def test_dense_point_sampling_converges_to_the_segment_integrals(kind):
    # n points per unit length at the midpoints of equal pieces: the point-MLS sums are
    # (n x) the midpoint rule for the segment integrals, whose error is O(h^2) at points
    # a fixed distance from the segments. So the difference must shrink 4x per halving
    # of h (it would stall if the closed forms integrated anything else).
    P2 = np.array([[[0.0, 0.0], [12.0, 0.0]], [[0.0, 6.0], [0.0, 14.0]], [[5, 5], [11, 13]]])
    Q2 = P2 + rng.normal(size=P2.shape)
    Xt = rng.uniform(-5, 17, size=(1500, 2))
    dist = np.min([np.linalg.norm(Xt - along(s, np.clip((Xt - s[0]) @ (s[1] - s[0])
                   / np.sum((s[1] - s[0]) ** 2), 0, 1)), axis=1) for s in P2], axis=0)
    Xt = Xt[dist > 1.0]
    U = mls_deform_lines(Xt, P2, Q2, kind=kind)

    def sample(S, h):
        return np.concatenate([s[0] + ((np.arange(n) + 0.5) / n)[:, None] * (s[1] - s[0])
                               for s, n in zip(S, np.round(np.linalg.norm(P2[:, 1] - P2[:, 0],
                                                                          axis=1) / h).astype(int))])
    err = np.array([np.abs(mls_deform(Xt, sample(P2, h), sample(Q2, h), kind=kind) - U).max()
                    for h in (0.5, 0.25, 0.125)])
    ratio = err[:-1] / err[1:]
    assert ((ratio > 3.5) & (ratio < 4.5)).all(), ratio
    assert err[-1] < 2e-3


def test_bad_input():
    with pytest.raises(ValueError):
        mls_deform_lines(X, P, Q[:2])
    with pytest.raises(ValueError):
        mls_deform_lines(X, P[:, 0], Q[:, 0])
    with pytest.raises(ValueError, match="positive length"):
        mls_deform_lines(X, np.array([[[1.0, 1.0], [1.0, 1.0]]]), Q[:1])
    with pytest.raises(ValueError):
        mls_deform_lines(X, P, Q, kind="bogus")
    with pytest.raises(ValueError):
        segment_weights(X, P, alpha=0)
    none = np.zeros((0, 2, 2))
    np.testing.assert_array_equal(mls_deform_lines(X, none, none), X)
