"""Mesh primitives: the shared input checks, edges and boundary edges."""
import numpy as np
import pytest

from puppet.geom.mesh import boundary_edges, check_faces, check_mesh, check_pins, check_vertices, edges

SQUARE_V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
SQUARE_F = np.array([[0, 1, 2], [0, 2, 3]])


def test_check_mesh_returns_clean_arrays():
    V, F, b = check_mesh(SQUARE_V.tolist(), SQUARE_F.astype(np.int32), [3, 1])
    assert V.dtype == np.float64 and V.flags.c_contiguous and V is not SQUARE_V
    assert F.dtype == np.int64 and b.dtype == np.int64
    np.testing.assert_array_equal(b, [3, 1])
    V, F = check_mesh(SQUARE_V, [])
    assert F.shape == (0, 3)
    assert check_pins([], 4).shape == (0,)


@pytest.mark.parametrize("V, F, b, message", [
    (np.zeros((4, 3)), SQUARE_F, [0], "shape"),
    ([[0.0, np.nan], [1, 0], [1, 1], [0, 1]], SQUARE_F, [0], "finite"),
    (SQUARE_V, [[0, 1, 4]], [0], "out of range"),
    (SQUARE_V, [[0, 1]], [0], "shape"),
    (SQUARE_V, [[0.0, 1.0, 2.0]], [0], "integer"),
    (SQUARE_V, SQUARE_F, [0, 4], "out of range"),
    (SQUARE_V, SQUARE_F, [1, 1], "repeated"),
    (SQUARE_V, SQUARE_F, [0.5], "integer"),
])
def test_check_mesh_rejects_bad_input(V, F, b, message):
    with pytest.raises(ValueError, match=message):
        check_mesh(V, F, b)


def test_three_dimensional_vertices_when_allowed():
    assert check_vertices(np.zeros((2, 3)), dims=(2, 3)).shape == (2, 3)
    assert check_faces(SQUARE_F, None).shape == (2, 3)


def test_edges_by_hand():
    np.testing.assert_array_equal(edges(SQUARE_F), [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]])
    # a triangle with a repeated vertex contributes no loop
    np.testing.assert_array_equal(edges([[0, 1, 1]]), [[0, 1]])


def test_boundary_edges_by_hand():
    # counter-clockwise square: the four sides, directed as in their triangles
    np.testing.assert_array_equal(boundary_edges(SQUARE_F), [[0, 1], [1, 2], [2, 3], [3, 0]])
    # a fan of four triangles around vertex 4 has the same boundary, no spoke
    fan = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    np.testing.assert_array_equal(boundary_edges(fan), [[0, 1], [1, 2], [2, 3], [3, 0]])
    assert boundary_edges(np.zeros((0, 3), int)).shape == (0, 2)
