"""Hand-checked pieces of the tracker: triangle maps, similarity fits, motion groups, ECC, clips."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from puppet.video.carry import PairMap, _triangle_affine
from puppet.video.features import match, motion_groups, similarity_fit, Features, apply_similarity
from puppet.video.refine import patch_radius, refine


def affine(A, t):
    return np.hstack([np.asarray(A, float), np.asarray(t, float)[:, None]])


def test_triangle_affine_is_eq_17_to_19():
    T0 = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    M = affine([[1.2, -0.3], [0.4, 0.9]], [5, -2])
    T1 = T0 @ M[:, :2].T + M[:, 2]
    A = _triangle_affine(T0, T1)
    assert A == pytest.approx(M)
    # barycentric: the centroid goes to the centroid
    assert A @ np.append(T0.mean(0), 1) == pytest.approx(T1.mean(0))
    # folded (mirror) and degenerate triangles are refused
    assert _triangle_affine(T0, T0[:, ::-1]) is None
    assert _triangle_affine(np.array([[0, 0], [1, 1], [2, 2.0]]), T1) is None
    # strongly sheared (singular values 4:1) too
    assert _triangle_affine(T0, T0 @ np.array([[4.0, 0], [0, 1]])) is None


def test_similarity_fit_recovers_a_turn_and_scale():
    rng = np.random.default_rng(0)
    X = rng.uniform(-50, 50, (12, 2))
    c_true = 1.1 * np.exp(1j * np.radians(20))
    Y = apply_similarity(c_true, np.zeros(2), np.array([3.0, 4.0]), X)
    c, mx, my = similarity_fit(X, Y, np.ones(len(X)))
    assert abs(c - c_true) < 1e-12
    assert apply_similarity(c, mx, my, np.array([[7.0, -9.0]])) == pytest.approx(
        apply_similarity(c_true, np.zeros(2), np.array([3.0, 4.0]), np.array([[7.0, -9.0]])))


def test_motion_groups_split_two_rigid_parts_and_drop_outliers():
    rng = np.random.default_rng(2)
    body = rng.uniform(0, 100, (30, 2))
    arm = rng.uniform(150, 200, (12, 2))
    src = np.vstack([body, arm, rng.uniform(0, 200, (3, 2))])
    R = np.array([[np.cos(0.5), -np.sin(0.5)], [np.sin(0.5), np.cos(0.5)]])
    dst = np.vstack([body + (5, 0), (arm - 175) @ R.T + 175, rng.uniform(0, 200, (3, 2)) + 60])
    g = motion_groups(src, dst)
    assert np.all(g[:30] == 0)
    assert np.all(g[30:42] == 1)
    assert np.all(g[42:] == -1)


def test_pairmap_carries_inside_by_triangle_and_outside_by_similarity():
    src = np.array([[0, 0], [100, 0], [0, 100], [100, 100], [50, 120.0]])
    M = affine([[0.98, -0.17], [0.17, 0.98]], [10, 20])  # a turn of ~10 degrees
    dst = src @ M[:, :2].T + M[:, 2]
    pm = PairMap(src, dst, np.zeros(len(src), int), radius=200)
    inside = pm.carry([30.0, 40.0])
    assert inside.how == "triangle" and inside.xy == pytest.approx(M @ [30, 40, 1])
    outside = pm.carry([-30.0, 50.0])
    assert outside.how == "local" and outside.xy == pytest.approx(M @ [-30, 50, 1], abs=0.5)
    assert inside.support == 5 and inside.resid < 0.5
    assert PairMap(src[:1], dst[:1], np.zeros(1, int)).carry([1.0, 2.0]) is None


def test_match_ratio_test_pairs_identical_descriptors():
    rng = np.random.default_rng(3)
    d = rng.random((20, 128)).astype(np.float32)
    a = Features(rng.random((20, 2)), d)
    b = Features(rng.random((20, 2)), d[::-1].copy())
    ia, ib = match(a, b)
    assert len(ia) == 20 and np.all(ib == 19 - ia)


@pytest.fixture(scope="module")
def blob() -> np.ndarray:
    """A 120x120 grey frame with a bright rotated square (corners) on a dark ground."""
    g = np.full((120, 120), 40, np.uint8)
    pts = cv2.boxPoints(((60, 60), (30, 20), 20)).astype(np.int32)
    cv2.fillPoly(g, [pts], 220)
    return cv2.GaussianBlur(g, (3, 3), 0)


def test_refine_recovers_a_shift_the_prediction_missed(blob):
    moved = cv2.warpAffine(blob, np.float64([[1, 0, 2.5], [0, 1, -1.5]]), (120, 120), borderValue=40)
    r = refine(blob, (60.0, 60.0), moved, affine(np.eye(2), [0, 0]), r=16)
    assert r.ok and r.rho > 0.95
    assert r.xy == pytest.approx([62.5, 58.5], abs=0.15)
    # the returned map includes the correction
    assert r.affine @ [60, 60, 1] == pytest.approx(r.xy)


def test_refine_keeps_the_prediction_on_flat_ground(blob):
    flat = np.full_like(blob, 90)
    pred = affine(np.eye(2), [3, 4])
    r = refine(flat, (20.0, 20.0), flat, pred, r=8)
    assert not r.ok and r.xy == pytest.approx([23, 24])


def test_patch_radius_small_at_corners_large_on_flat_ground(blob):
    radii = [8, 12, 16, 24, 32]
    corner = cv2.boxPoints(((60, 60), (30, 20), 20))[0]
    assert patch_radius(blob, corner, radii, min_eig=300) == 8
    assert patch_radius(blob, (60, 60), radii, min_eig=300) > 8  # inside the flat square
    assert patch_radius(np.full_like(blob, 90), (60, 60), radii) == 32


@pytest.mark.gl
def test_ground_truth_clip_is_deterministic_and_its_truth_on_the_character(tmp_path, monkeypatch):
    from puppet.video.clips import generate_clip, load_clip

    monkeypatch.setenv("PUPPET_CACHE", str(tmp_path))
    a = generate_clip("trex", n=3, size=(160, 120))
    b = load_clip("trex", n=3, size=(160, 120))  # generated again, then cached
    c = load_clip("trex", n=3, size=(160, 120))  # from the cache
    assert a.frames.shape == (3, 120, 160, 3)
    for x in (b, c):
        assert np.array_equal(a.frames, x.frames) and np.array_equal(a.masks, x.masks)
        for k in a.joints:
            assert np.array_equal(a.joints[k], x.joints[k])
    assert list((tmp_path / "video-gt").iterdir())
    # every visible joint lies on the character's foreground (within a pixel)
    grown = np.array([cv2.dilate(m.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0 for m in a.masks])
    for k, xy in a.joints.items():
        for i in range(3):
            x, y = np.round(xy[i]).astype(int)
            assert grown[i, y, x], (k, i)
    # the swung jaw moves against the body: its truth is not the global motion of the hip
    d_jaw = a.joints["jaw"][2] - a.joints["jaw"][0]
    d_hip = a.joints["hip"][2] - a.joints["hip"][0]
    assert np.hypot(*(d_jaw - d_hip)) > 1.0


def test_bunched_matches_with_a_wild_scale_move_the_point_by_their_mean():
    src = np.array([[50.0, 50.0], [51.0, 50.0]])
    dst = np.array([[60.0, 40.0], [80.0, 40.0]])  # 1 px apart -> 20 px apart: not a real scale
    c = PairMap(src, dst, np.zeros(2, int)).carry([50.5, 150.0])  # as far from both
    assert c.how == "local" and c.xy == pytest.approx([50.5 + 19.5, 150 - 10], abs=1e-9)
