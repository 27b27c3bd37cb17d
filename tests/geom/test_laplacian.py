import numpy as np
import pytest
import scipy.sparse as sp
import triangle

from puppet.geom.laplacian import (
    cotangent_laplacian,
    cotangent_weights,
    edges,
    uniform_laplacian,
    uniform_weights,
)

SQUARE_V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
SQUARE_F = np.array([[0, 1, 2], [0, 2, 3]])


def l_shape(max_area=0.02):
    pts = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    seg = np.c_[np.arange(6), (np.arange(6) + 1) % 6]
    T = triangle.triangulate({"vertices": pts, "segments": seg}, f"pq25a{max_area}")
    return T["vertices"], T["triangles"]


def test_edges_of_square_are_unique_and_sorted():
    E = edges(SQUARE_F)
    np.testing.assert_array_equal(E, [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]])


def test_right_triangle_weights_by_hand():
    # angles: 90 deg at vertex 0, 45 deg at 1 and 2
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    W = cotangent_weights(V, np.array([[0, 1, 2]])).toarray()
    expected = np.array([[0, 0.5, 0.5], [0.5, 0, 0], [0.5, 0, 0]])  # cot45/2, cot90/2 = 0
    np.testing.assert_allclose(W, expected, atol=1e-15)


def test_3_4_5_triangle_weights_by_hand():
    V = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]])
    W = cotangent_weights(V, np.array([[0, 1, 2]])).toarray()
    # edge 0-2 is opposite the angle at (4,0): cot = 4/3; edge 0-1 opposite (0,3): cot = 3/4
    assert W[0, 2] == pytest.approx(0.5 * 4 / 3)
    assert W[0, 1] == pytest.approx(0.5 * 3 / 4)
    assert W[1, 2] == pytest.approx(0.0, abs=1e-15)


def test_unit_square_split_in_two_by_hand():
    L = cotangent_laplacian(SQUARE_V, SQUARE_F).toarray()
    # boundary edges: one 45 deg angle opposite -> 0.5; diagonal 0-2: two right angles -> 0
    expected = np.array([
        [1.0, -0.5, 0.0, -0.5],
        [-0.5, 1.0, -0.5, 0.0],
        [0.0, -0.5, 1.0, -0.5],
        [-0.5, 0.0, -0.5, 1.0],
    ])
    np.testing.assert_allclose(L, expected, atol=1e-15)


def test_equilateral_triangle():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    W = cotangent_weights(V, np.array([[0, 1, 2]])).toarray()
    w = 0.5 / np.sqrt(3)
    np.testing.assert_allclose(W, w * (1 - np.eye(3)), atol=1e-15)


def test_orientation_does_not_matter():
    V, F = l_shape()
    W1 = cotangent_weights(V, F)
    W2 = cotangent_weights(V, F[:, ::-1])
    assert abs(W1 - W2).max() < 1e-14


def test_3d_vertices_give_same_weights_as_2d():
    V, F = l_shape()
    V3 = np.c_[V, np.zeros(len(V))]
    assert abs(cotangent_weights(V, F) - cotangent_weights(V3, F)).max() < 1e-14


@pytest.mark.parametrize("build", [cotangent_laplacian, uniform_laplacian])
def test_laplacian_symmetric_rows_sum_zero_psd(build):
    V, F = l_shape(0.05)
    L = build(V, F)
    assert sp.isspmatrix_csr(L) or isinstance(L, sp.csr_array)
    assert L.shape == (len(V), len(V))
    assert abs(L - L.T).max() < 1e-14
    np.testing.assert_allclose(np.asarray(L.sum(axis=1)).ravel(), 0, atol=1e-12)
    ev = np.linalg.eigvalsh(L.toarray())
    assert ev.min() > -1e-10
    # connected mesh: exactly one zero eigenvalue (the constants)
    assert np.sum(ev < 1e-9) == 1


def test_cotangent_laplacian_is_exact_on_linear_functions():
    # linear precision: L x = 0 at interior vertices for x = a linear function
    V, F = l_shape()
    L = cotangent_laplacian(V, F)
    E = edges(F)
    boundary = set()
    half = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(half, axis=0, return_counts=True)
    for i, j in uniq[count == 1]:
        boundary.update((i, j))
    interior = np.array(sorted(set(range(len(V))) - boundary))
    assert len(interior) > 10 and len(E) > 0
    f = 3.0 * V[:, 0] - 2.0 * V[:, 1] + 1.0
    np.testing.assert_allclose((L @ f)[interior], 0, atol=1e-11)


def test_uniform_weights_on_square():
    W = uniform_weights(SQUARE_V, SQUARE_F).toarray()
    expected = np.array([[0, 1, 1, 1], [1, 0, 1, 0], [1, 1, 0, 1], [1, 0, 1, 0]], float)
    np.testing.assert_array_equal(W, expected)
    L = uniform_laplacian(SQUARE_V, SQUARE_F).toarray()
    np.testing.assert_array_equal(np.diag(L), [3, 2, 3, 2])
    np.testing.assert_array_equal(L, np.diag([3, 2, 3, 2]) - expected)


def test_shared_edge_sums_both_triangles():
    # two triangles sharing edge 1-2, both with a 60 deg angle opposite it
    h = np.sqrt(3) / 2
    V = np.array([[0.5, -h], [0.0, 0.0], [1.0, 0.0], [0.5, h]])
    W = cotangent_weights(V, np.array([[0, 2, 1], [1, 2, 3]])).toarray()
    assert W[1, 2] == pytest.approx(1 / np.sqrt(3))  # (cot60 + cot60)/2
    assert W[0, 1] == pytest.approx(0.5 / np.sqrt(3))
    assert W[0, 3] == 0.0


def test_bad_faces_raise():
    with pytest.raises(ValueError):
        cotangent_weights(SQUARE_V, np.array([[0, 1, 7]]))
    with pytest.raises(ValueError):
        cotangent_weights(SQUARE_V, np.array([[0.0, 1.0, 2.0]]))


def test_obtuse_triangle_weight_is_negative_unless_clamped():
    # angle of 120 degrees at vertex 2, opposite edge 0-1: cot 120 / 2 = -1 / (2 sqrt 3)
    V = np.array([[-np.sqrt(3) / 2, 0.0], [np.sqrt(3) / 2, 0.0], [0.0, 0.5]])
    F = np.array([[0, 1, 2]])
    assert cotangent_weights(V, F)[0, 1] == pytest.approx(-0.5 / np.sqrt(3))
    W = cotangent_weights(V, F, clamp=True)
    assert W[0, 1] == 0.0 and W[0, 2] == pytest.approx(0.5 * np.sqrt(3))


def test_every_edge_is_stored_even_with_zero_weight():
    # the square's diagonal has weight 0 (two right angles) but stays in the pattern,
    # which is the mesh's edge list (the ARAP solver builds its geodesic graph on it)
    for W in (cotangent_weights(SQUARE_V, SQUARE_F), uniform_weights(SQUARE_V, SQUARE_F)):
        rows = np.repeat(np.arange(4), np.diff(W.indptr))
        upper = rows < W.indices
        np.testing.assert_array_equal(np.c_[rows[upper], W.indices[upper]], edges(SQUARE_F))
    assert cotangent_weights(SQUARE_V, SQUARE_F)[0, 2] == 0.0


def test_3d_weights_of_a_bent_pair_by_hand():
    # two right isosceles triangles folded 90 degrees about their shared leg 0-1, the
    # right angle at vertex 0 in both: the leg is opposite a 45-degree angle in each
    # (cot 1, twice), the other legs 0-2 and 0-3 in one (cot 1), the hypotenuses 1-2
    # and 1-3 opposite the right angles (cot 0)
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    W = cotangent_weights(V, np.array([[0, 1, 2], [0, 1, 3]])).toarray()
    assert W[0, 1] == pytest.approx(1.0)
    assert W[0, 2] == pytest.approx(0.5) and W[0, 3] == pytest.approx(0.5)
    assert W[1, 2] == pytest.approx(0.0, abs=1e-15) and W[1, 3] == pytest.approx(0.0, abs=1e-15)
