import numpy as np
import pytest

from puppet.geom.geodesic import connected_components, geodesic_distances


def strip(m=5):
    """Unit-height strip: bottom (i, 0) = i, top (i, 1) = m + i, diagonals i -> m+i+1."""
    V = np.array([[i, 0.0] for i in range(m)] + [[i, 1.0] for i in range(m)])
    F = []
    for i in range(m - 1):
        F += [[i, i + 1, m + i + 1], [i, m + i + 1, m + i]]
    return V, np.array(F)


def test_path_along_strip_by_hand():
    V, F = strip(5)
    D = geodesic_distances(V, F, [0])
    assert D.shape == (1, 10)
    d = D[0]
    np.testing.assert_allclose(d[:5], [0, 1, 2, 3, 4])  # along the bottom
    assert d[5] == pytest.approx(1.0)  # straight up
    assert d[6] == pytest.approx(np.sqrt(2))  # the diagonal
    # top-right corner: one diagonal + 3 top edges, not Euclidean sqrt(17)
    assert d[9] == pytest.approx(3 + np.sqrt(2))
    assert d[9] > np.hypot(4, 1) + 0.2


def test_several_sources_and_symmetry():
    V, F = strip(5)
    D = geodesic_distances(V, F, np.array([0, 9, 0]))
    assert D.shape == (3, 10)
    np.testing.assert_array_equal(D[0], D[2])
    assert D[0, 9] == pytest.approx(D[1, 0])
    assert D[1, 9] == 0.0


def test_unreachable_is_inf():
    V, F = strip(3)
    # a second triangle far away, plus an isolated vertex
    V2 = np.r_[V, [[10.0, 0.0], [11.0, 0.0], [10.0, 1.0], [20.0, 20.0]]]
    F2 = np.r_[F, [[6, 7, 8]]]
    D = geodesic_distances(V2, F2, [0, 7])
    assert np.all(np.isinf(D[0, 6:]))
    assert np.all(np.isfinite(D[0, :6]))
    assert np.all(np.isinf(D[1, :6])) and np.isinf(D[1, 9])
    np.testing.assert_allclose(D[1, 6:9], [1, 0, np.sqrt(2)])


def test_zero_length_edge_is_an_edge():
    V = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    D = geodesic_distances(V, np.array([[0, 1, 2]]), [2])
    np.testing.assert_allclose(D[0], [1, 1, 0])


def test_no_sources():
    V, F = strip(3)
    assert geodesic_distances(V, F, []).shape == (0, 6)


def test_connected_components():
    V, F = strip(3)
    F2 = np.r_[F, [[6, 7, 8]]]
    ncomp, labels = connected_components(10, F2)
    assert ncomp == 3  # strip, triangle, isolated vertex 9
    assert len(set(labels[:6])) == 1
    assert len(set(labels[6:9])) == 1
    assert labels[0] != labels[6] != labels[9] != labels[0]
    assert connected_components(4, np.zeros((0, 3), int))[0] == 4
