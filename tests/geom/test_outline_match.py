"""Outline alignment, landmark correspondence and mean value coordinates: hand-checked
cases and invariants."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.geom.curvature import resample_closed
from puppet.geom.mvc import mean_value_coordinates
from puppet.geom.outline_corr import (LandmarkRing, correspondence_distance, match_landmarks, match_outlines,
                                      outline_correspondence, smooth_ring)
from puppet.geom.outline_match import (Similarity, align_outlines, oriented, ring_centroid, similarity_fit,
                                       symmetric_mean_distance)

# an asymmetric "t-shirt": body, two sleeves of different length, a notch at the neck
SHIRT = np.array([[0, 0], [30, 0], [36, 6], [44, 0], [74, 0], [100, 20], [92, 34], [74, 22], [74, 90],
                  [0, 90], [0, 22], [-14, 30], [-22, 18]], float)


def sim(scale, deg, shift) -> Similarity:
    return Similarity(complex(scale * np.exp(1j * np.radians(deg))), complex(*shift))


def test_similarity_apply_by_hand():
    S = sim(2.0, 90.0, (1.0, 0.0))  # z -> 2i z + 1: (1, 0) -> (1, 2); (0, 1) -> (-1, 0)
    assert np.allclose(S.apply([[1, 0], [0, 1]]), [[1, 2], [-1, 0]])
    assert np.allclose(S.apply_vector([[1, 0]]), [[0, 2]])
    assert S.scale == pytest.approx(2.0) and S.angle == pytest.approx(90.0)


def test_similarity_fit_recovers_a_known_similarity():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(20, 2)) * 50
    S = sim(0.7, -33.0, (12.0, -4.0))
    F = similarity_fit(A, S.apply(A))
    assert abs(F.a - S.a) < 1e-12 and abs(F.b - S.b) < 1e-9
    # no reflection: a mirrored copy is fitted by a similarity, not matched exactly
    M = A * [-1, 1]
    assert np.abs(similarity_fit(A, M).apply(A) - M).max() > 1.0


def test_ring_centroid_of_a_rectangle_and_orientation():
    R = np.array([[0, 0], [4, 0], [4, 2], [0, 2]], float)
    c, a = ring_centroid(R)
    assert np.allclose(c, [2, 1]) and a == pytest.approx(8.0)
    c2, a2 = ring_centroid(R[::-1])
    assert np.allclose(c2, [2, 1]) and a2 == pytest.approx(8.0)
    assert np.array_equal(oriented(R[::-1]), R[::-1][::-1])


def test_symmetric_mean_distance_of_concentric_squares():
    def square(h):
        return np.array([[-h, -h], [h, -h], [h, h], [-h, h]], float)

    # every point of the inner square is 1 from the outer one; outer points are 1 from
    # the inner square except on the corner stretches (up to sqrt 2): mean 1.0 .. 1.05
    d = symmetric_mean_distance(square(5), square(6), step=0.01)
    inner = symmetric_mean_distance(square(5), square(5), step=0.01)
    assert inner < 0.01
    assert 1.0 <= d <= 1.05


@pytest.mark.parametrize("scale,deg,shift", [(1.0, 0.0, (0, 0)), (0.5, 170.0, (300, 20)), (3.0, -60.0, (-5, 7))])
def test_align_outlines_recovers_a_similarity(scale, deg, shift):
    P = resample_closed(SHIRT, 400)
    S = sim(scale, deg, shift)
    Q = S.apply(P)[::-1]  # other direction and another start: still the same outline
    Q = np.roll(Q, 37, axis=0)
    F, score = align_outlines(P, Q)
    assert abs(F.a - S.a) < 0.01 * scale
    assert np.abs(F.apply(P) - S.apply(P)).max() < 0.02 * scale * 100
    assert score < 0.005


def test_match_landmarks_by_hand():
    A = np.array([[0, 0], [10, 0], [10, 10]], float)
    B = np.array([[10, 10.5], [50, 50], [0, 0.5], [10, 0.2]], float)  # B starts elsewhere and has an outlier
    assert match_landmarks(A, B, gate=2.0) == [(0, 2), (1, 3), (2, 0)]
    # order is kept: swapping two landmarks of B can match only one of them
    pairs = match_landmarks(A, np.array([[10, 0], [0, 0], [10, 10]], float), gate=2.0)
    assert len(pairs) == 2
    assert match_landmarks(A, np.zeros((0, 2)), gate=2.0) == []


def test_correspondence_of_a_similar_copy_is_the_similarity():
    S = sim(1.7, 40.0, (100, -30))
    p = LandmarkRing.of(SHIRT, smooth=0)  # exact polygons: no pixel staircase to smooth
    q = LandmarkRing.of(S.apply(SHIRT)[::-1], smooth=0)
    corr = outline_correspondence(p, q, S)
    assert len(corr.anchors) == len(p.landmarks) >= 6  # every corner matched
    # landmarks sit on samples: within one sample spacing of the exact correspondence
    assert np.linalg.norm(corr.corresponding_ring() - S.apply(p.R), axis=1).max() < q.h
    s = np.linspace(0, p.L, 50, endpoint=False)
    back = corr.unmap_arclength(corr.map_arclength(s))
    d = np.abs(back - s)
    assert np.minimum(d, p.L - d).max() < 1e-6
    assert correspondence_distance(corr, S) < 0.003


def test_match_outlines_scores_shape_difference():
    circle = np.stack([np.cos(np.linspace(0, 2 * np.pi, 300, endpoint=False)),
                       np.sin(np.linspace(0, 2 * np.pi, 300, endpoint=False))], axis=1) * 60 + 50
    same = match_outlines(SHIRT, sim(0.8, 15, (3, 4)).apply(SHIRT))
    other = match_outlines(SHIRT, circle)
    assert same.score < 0.005
    assert other.score > 0.08 and other.distance < other.score  # nearest points understate it


def test_smooth_ring_removes_the_staircase_length():
    # a 45-degree staircase square (diamond of radius 40 drawn with unit steps) is ~sqrt(2)
    # too long; smoothed over a pixel its length is within 1% of the diamond's
    steps = []
    for (x0, y0), (dx, dy) in zip([(40, 0), (0, 40), (-40, 0), (0, -40)], [(-1, 1), (-1, -1), (1, -1), (1, 1)]):
        for k in range(40):
            steps += [(x0 + k * dx, y0 + k * dy), (x0 + (k + 1) * dx, y0 + k * dy)]
    P = np.array(steps, float)

    def length(R):
        return np.linalg.norm(np.roll(R, -1, axis=0) - R, axis=1).sum()

    true = 4 * 40 * np.sqrt(2)
    assert length(P) == pytest.approx(true * np.sqrt(2), rel=1e-9)
    assert length(smooth_ring(P, 1.0)) == pytest.approx(true, rel=0.01)
    assert np.allclose(length(smooth_ring(P, 0.0)), length(P), rtol=1e-3)


def test_mean_value_coordinates_hand_checked_and_invariants():
    sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    assert np.allclose(mean_value_coordinates(sq, [[1, 1]]), 0.25)
    # on a vertex and on an edge
    assert np.allclose(mean_value_coordinates(sq, [[2, 0]]), [[0, 1, 0, 0]])
    assert np.allclose(mean_value_coordinates(sq, [[1, 0]]), [[0.5, 0.5, 0, 0]])
    # a non-convex polygon: rows sum to 1 and reproduce the points
    P = SHIRT
    X = np.array([[10, 10], [60, 80], [-10, 24], [90, 22], [37, 5]], float)
    L = mean_value_coordinates(P, X)
    assert np.allclose(L.sum(axis=1), 1) and np.allclose(L @ P, X)
    # similarity invariance: same coordinates in a moved copy
    S = sim(2.5, 70, (9, 9))
    assert np.allclose(mean_value_coordinates(S.apply(P), S.apply(X)), L)
    assert np.allclose(mean_value_coordinates(P[::-1], X), L[:, ::-1])
