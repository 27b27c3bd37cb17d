"""The pose-independent weights kept per mesh and pin set (issue 31) give exactly the
results of computing them again."""
import numpy as np

from puppet.deform.arap import arap_precompute
from puppet.deform.depth import depth_field
from puppet.deform.hinge import hinge_guess, hinge_weights
from puppet.deform.mls import distance_weights, mls_object_space
from tests.deform.meshes import nearest, rectangle, two_squares


def bent_grid():
    V, F = rectangle(24, 8, 1.0)
    b = nearest(V, [[0, 0], [0, 8], [24, 0], [24, 8]])
    bc = V[b].copy()
    bc[2:] += [[-6.0, 9.0], [-6.0, 9.0]]
    return V, F, b, bc


def test_kept_mls_weights_equal_fresh_ones():
    V, F, b, bc = bent_grid()
    a = arap_precompute(V, F, b)
    assert a.mls_weights() is a.mls_weights()  # computed once
    for got, want in zip(a.mls_weights(), distance_weights(a.D, alpha=a.alpha)):
        assert np.array_equal(got, want)
    assert np.array_equal(mls_object_space(V, a.D, bc, V[b], weights=a.mls_weights()),
                          mls_object_space(V, a.D, bc, V[b]))


def test_kept_weights_give_the_same_depth_field():
    V, F, b, _ = bent_grid()
    a = arap_precompute(V, F, b, alpha=1.5)
    z = np.array([0.0, 2.0, -1.0, 0.5])
    assert np.array_equal(depth_field(a.D, z, alpha=1.5, weights=a.mls_weights()), depth_field(a.D, z, alpha=1.5))


def test_kept_hinge_weights_give_the_same_guess():
    V, parts, P, bc, D, DH = two_squares()
    args = (np.array([0, 0, 1]), parts, np.array([[1, 5]]), DH)
    w = hinge_weights(D, *args, alpha=1.0)
    assert all(p is not None for p in w.parts)
    assert np.array_equal(hinge_guess(V, D, P, bc, *args, weights=w), hinge_guess(V, D, P, bc, *args))
    assert np.allclose(hinge_guess(V, D, P, bc, *args, weights=w)[4], [20, -10])
