"""Relative-form targets (hand-checked), the frame warp (direction, moved point, untouched
background) and the per-frame masks."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.video.retarget import relative_skeleton
from puppet.video.segment import clean_mask
from puppet.video.warp import backward_map, background_fill, composite, grid_mesh, skeleton_maps
from tests.video.video_helpers import character_mask, frame


def rot(deg):
    t = np.radians(deg)
    return np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])


# ---- relative form --------------------------------------------------------------------

P = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])  # root, elbow, hand
BONES = [(0, 1), (1, 2)]


def test_relative_form_on_a_rotated_scaled_skeleton_by_hand():
    T = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])  # forearm turned +90 deg
    rel = relative_skeleton(P, T, BONES)
    np.testing.assert_allclose(rel.apply(P), T, atol=1e-12)
    # the whole arm turned by +90 deg (x -> -y), scaled 2, moved by (5, 5): elbow at (5, 25),
    # hand at (5, 45); the forearm bone (0, 20) turned +90 deg with alpha 1 is (-20, 0)
    J = np.array([[5.0, 5.0], [5.0, 25.0], [5.0, 45.0]])
    np.testing.assert_allclose(rel.apply(J), [[5, 5], [5, 25], [-15, 25]], atol=1e-12)


def test_relative_form_follows_each_bone_on_its_own():
    T = np.array([[0.0, 0.0], [10.0, 0.0], [25.0, 0.0]])  # forearm stretched 1.5x
    rel = relative_skeleton(P, T, BONES)
    # on a frame where only the forearm turned by 90 deg: the stretch follows it
    J = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    np.testing.assert_allclose(rel.apply(J), [[0, 0], [10, 0], [10, 15]], atol=1e-12)


def test_relative_form_commutes_with_similarities():
    rng = np.random.default_rng(3)
    P5 = rng.uniform(0, 100, (5, 2))
    bones = [(0, 1), (1, 2), (1, 3), (3, 4)]
    T5 = P5 + rng.normal(0, 8, (5, 2))  # every pin moves, the root too
    rel = relative_skeleton(P5, T5, bones)
    np.testing.assert_allclose(rel.apply(P5), T5, atol=1e-9)
    for deg, s, t in ((30, 1.0, (4, -2)), (-75, 0.6, (100, 3)), (180, 2.5, (0, 0))):
        S = lambda X: s * X @ rot(deg).T + np.array(t)  # noqa: E731
        np.testing.assert_allclose(rel.apply(S(P5)), S(T5), atol=1e-9)


def test_a_pin_on_no_bone_keeps_its_offset():
    P2 = np.r_[P, [[50.0, 50.0]]]
    T2 = np.r_[P, [[53.0, 46.0]]]
    rel = relative_skeleton(P2, T2, BONES)
    np.testing.assert_allclose(rel.apply(P2 + [1, 1])[3], [54, 47])


# ---- warp -----------------------------------------------------------------------------

JOINTS = np.array([[80.0, 80.0], [80.0, 45.0], [124.0, 45.0]])  # OpenCV coordinates
WBONES = np.array([[0, 1], [1, 2]])


def test_grid_mesh_puts_the_joints_on_vertices():
    V, F, b = grid_mesh(character_mask(), 6, JOINTS)
    np.testing.assert_array_equal(V[b], JOINTS)
    assert len(set(b.tolist())) == 3 and F.max() < len(V)


def test_translation_moves_the_character_and_nothing_else():
    rgb, mask = frame(), character_mask()
    maps = skeleton_maps(mask, JOINTS, JOINTS + [10, 5], WBONES)
    inner = np.argwhere(mask[32:93, 72:88]) + [32, 72]
    np.testing.assert_allclose(maps.mapx[inner[:, 0] + 5, inner[:, 1] + 10], inner[:, 1], atol=1e-3)
    np.testing.assert_allclose(maps.mapy[inner[:, 0] + 5, inner[:, 1] + 10], inner[:, 0], atol=1e-3)
    out = composite(rgb, background_fill(rgb, mask), mask, maps)
    ys, xs = inner[:, 0], inner[:, 1]
    np.testing.assert_array_equal(out[ys + 5, xs + 10], rgb[ys, xs])  # the backward map is f's inverse


def test_the_hand_goes_to_its_target_and_the_background_stays():
    rgb, mask = frame(), character_mask()
    T = JOINTS.copy()
    T[2] = JOINTS[1] + 44 * np.array([np.cos(np.radians(-60)), np.sin(np.radians(-60))])  # arm up 60 deg
    maps = skeleton_maps(mask, JOINTS, T, WBONES)
    bg = background_fill(rgb, mask)
    out = composite(rgb, bg, mask, maps)
    # the hand's pixel lands on the target and reads the hand
    ty, tx = int(round(T[2, 1])), int(round(T[2, 0]))
    assert abs(maps.mapx[ty, tx] - JOINTS[2, 0]) < 1.0 and abs(maps.mapy[ty, tx] - JOINTS[2, 1]) < 1.0
    assert out[ty, tx, 0] > 180 and out[ty, tx, 1] < 80
    # where the arm was, the background shows again (no copy of the arm left behind)
    assert (out[44:48, 100:115] > 200).all()
    # outside the character's band (old mask grown by the fill, new place) nothing changed
    import cv2

    warped = cv2.remap(mask.astype(np.float32), maps.mapx, maps.mapy, cv2.INTER_LINEAR) > 0
    band = cv2.dilate((mask | warped).astype(np.uint8), np.ones((9, 9), np.uint8)) > 0
    assert (~band).sum() > 0.6 * band.size
    np.testing.assert_array_equal(out[~band], rgb[~band])
    np.testing.assert_array_equal(bg[~band], rgb[~band])


def test_rest_targets_give_back_the_frame_inside_the_character():
    rgb, mask = frame(), character_mask()
    maps = skeleton_maps(mask, JOINTS, JOINTS, WBONES)
    out = composite(rgb, background_fill(rgb, mask), mask, maps)
    np.testing.assert_array_equal(out[mask], rgb[mask])


def test_backward_map_of_one_triangle_by_hand():
    V = np.array([[0.0, 0.0], [8.0, 0.0], [0.0, 8.0]])
    U = V * 2 + [4.0, 4.0]  # scaled 2 and moved: sample (x, y) reads ((x - 4) / 2, (y - 4) / 2)
    src, cov = backward_map(U, V, np.array([[0, 1, 2]]), (32, 32), 1)
    assert cov[4, 4] and cov[4, 19] and cov[19, 4] and not cov[19, 19] and not cov[3, 3]
    np.testing.assert_allclose(src[10, 6], [1.0, 3.0])


# ---- masks ----------------------------------------------------------------------------

def test_clean_mask_fills_holes_and_drops_specks():
    m = character_mask()
    noisy = m.copy()
    noisy[60:64, 76:80] = False  # an eye white inside
    noisy[5, 5] = True  # a speck
    np.testing.assert_array_equal(clean_mask(noisy), m)


@pytest.mark.parametrize("dx", [0, 7])
def test_threshold_segmenter_follows_the_character(dx):
    from types import SimpleNamespace

    from puppet.scene.format.model import Mask
    from puppet.video.segment import Segmenter

    layer = SimpleNamespace(mask=Mask("threshold", threshold=150), offset=(0.0, 0.0), index=0, name="body")
    rgba = np.dstack([frame(dx), np.full(frame().shape[:2], 255, np.uint8)])
    seg = Segmenter(layer, rgba)
    np.testing.assert_array_equal(seg(rgba), character_mask(dx))


def test_grabcut_segmenter_is_seeded_from_the_previous_frame():
    from types import SimpleNamespace

    from puppet.scene.format.model import Mask
    from puppet.video.segment import Segmenter

    def rgba(dx):
        return np.dstack([frame(dx), np.full(frame().shape[:2], 255, np.uint8)])

    layer = SimpleNamespace(mask=Mask("grabcut", rect=(60, 20, 80, 85)), offset=(0.0, 0.0), index=0, name="body")
    seg = Segmenter(layer, rgba(0))
    for dx in (0, 3, 6, 30):  # the last step leaves the first frame's rectangle
        m, truth = seg(rgba(dx)), character_mask(dx)
        iou = (m & truth).sum() / (m | truth).sum()
        assert iou > 0.9, (dx, iou)


def test_the_plate_gives_back_the_background_seen_before():
    from puppet.video.plate import Plate

    rng = np.random.default_rng(1)
    back = rng.integers(100, 256, size=frame().shape, dtype=np.uint8)  # a textured background
    m0, m1 = character_mask(0), character_mask(30)
    f0, f1 = back.copy(), back.copy()
    f0[m0], f1[m1] = 20, 20
    plate = Plate()
    plate.apply(f0, m0, f0)
    filled1 = background_fill(f1, m1)
    out = plate.apply(f1, m1, filled1)
    seen = ~plate._hole(m0) & plate._hole(m1)  # behind the character now, free on frame 0
    assert seen.sum() > 500
    np.testing.assert_array_equal(out[seen], back[seen])  # exact, where inpainting only guesses
    assert np.abs(filled1[seen].astype(int) - back[seen]).mean() > 20
    unseen = plate._hole(m0) & plate._hole(m1)
    np.testing.assert_array_equal(out[unseen], filled1[unseen])
    # a moved camera: the plate no longer matches around the character and is dropped
    shifted = np.roll(f1, 9, axis=1)
    out2 = plate.apply(shifted, np.roll(m1, 9, axis=1), shifted)
    np.testing.assert_array_equal(out2, shifted)
