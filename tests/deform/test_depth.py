import numpy as np
import pytest
import triangle

from puppet.deform.depth import depth_field
from puppet.geom.geodesic import geodesic_distances


def rectangle(w=4.0, h=1.0, max_area=0.01):
    pts = np.array([[0, 0], [w, 0], [w, h], [0, h]], float)
    T = triangle.triangulate({"vertices": pts, "segments": [[0, 1], [1, 2], [2, 3], [3, 0]]},
                             f"pq30a{max_area}")
    return T["vertices"], T["triangles"]


V, F = rectangle()
PINS = np.array([0, 1, 2])  # three corners
D = geodesic_distances(V, F, PINS)


def test_constant_pin_depths_give_flat_field():
    z = depth_field(D, [-2.0, -2.0, -2.0])
    np.testing.assert_allclose(z, -2.0, atol=1e-14)


def test_exact_values_at_pins_and_within_range():
    zp = np.array([-3.0, 1.5, 0.25])
    z = depth_field(D, zp)
    np.testing.assert_array_equal(z[PINS], zp)
    assert z.min() >= zp.min() and z.max() <= zp.max()
    # it actually varies between the pins
    assert np.ptp(z) > 3.0


def test_hand_checked_weights():
    # one vertex at distances 1 and 3 from two pins: weights 1 and 1/9
    Dh = np.array([[1.0, 0.0], [3.0, 5.0]])
    z = depth_field(Dh, [0.0, 1.0], alpha=1.0)
    assert z[0] == pytest.approx((1 / 9) / (1 + 1 / 9))
    assert z[1] == 0.0
    z2 = depth_field(Dh, [0.0, 1.0], alpha=0.5)  # weights 1 and 1/3
    assert z2[0] == pytest.approx((1 / 3) / (1 + 1 / 3))


def test_unreachable_is_zero_and_no_pins_gives_zeros():
    Dh = np.array([[np.inf, 2.0], [np.inf, np.inf]])
    z = depth_field(Dh, [4.0, -7.0])
    np.testing.assert_array_equal(z, [0.0, 4.0])
    np.testing.assert_array_equal(depth_field(np.zeros((0, 5)), []), np.zeros(5))


def test_shape_mismatch_raises():
    with pytest.raises(ValueError):
        depth_field(D, [1.0, 2.0])
