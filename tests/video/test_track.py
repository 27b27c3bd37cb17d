"""Tracker on small clips made by warping a real picture with known transforms."""
from __future__ import annotations

import os

import cv2
import numpy as np
import pytest
from PIL import Image

from puppet.video.track import Tracker, Tracks, track

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
W, H = 320, 240
BLUE = (61, 122, 186)


@pytest.fixture(scope="module")
def picture() -> np.ndarray:
    """A 320x240 RGB frame: the four Kenney characters on their blue background."""
    im = np.array(Image.open(os.path.join(ROOT, "assets", "kenney-character", "Sample.png")).convert("RGB"))
    group = cv2.resize(im[90:370, 120:530], (240, 164), interpolation=cv2.INTER_AREA)
    frame = np.empty((H, W, 3), np.uint8)
    frame[:] = BLUE
    frame[38:202, 40:280] = group
    return frame


# joints on the characters (faces, hands, feet), in frame pixels
JOINTS = {"a": (95.0, 80.0), "b": (140.0, 95.0), "c": (180.0, 100.0), "d": (220.0, 110.0),
          "e": (120.0, 180.0), "f": (200.0, 175.0)}


def warp(frame: np.ndarray, M: np.ndarray) -> np.ndarray:
    return cv2.warpAffine(frame, M, (W, H), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                          borderValue=BLUE)


def moved(M: np.ndarray) -> dict[str, tuple[float, float]]:
    P = np.array(list(JOINTS.values()))
    Q = P @ M[:, :2].T + M[:, 2]
    return dict(zip(JOINTS, map(tuple, Q)))


def similarity(angle: float = 0.0, scale: float = 1.0, tx: float = 0.0, ty: float = 0.0) -> np.ndarray:
    M = cv2.getRotationMatrix2D((W / 2, H / 2), angle, scale)
    M[:, 2] += (tx, ty)
    return M


def errors(tr: Tracks, truths: list[dict]) -> np.ndarray:
    """(frames, joints) distances between tracked and true positions."""
    return np.array([[np.hypot(*(tr.joints[n][i] - t[n])) for n in JOINTS] for i, t in enumerate(truths)])


def test_static_clip_has_zero_drift(picture):
    tr = track([picture] * 6, JOINTS)
    assert tr.lost_frames == []
    for n, (x, y) in JOINTS.items():
        assert np.abs(tr.joints[n] - [x, y]).max() < 1e-9
        assert np.all(tr.confidence[n] > 0.5)


@pytest.mark.parametrize("kind", ["translate", "rotate", "scale", "all"])
def test_known_transform_within_one_pixel(picture, kind):
    Ms = []
    for t in np.linspace(0, 1, 8):
        Ms.append({"translate": similarity(tx=25 * t, ty=-12 * t),
                   "rotate": similarity(angle=25 * t),
                   "scale": similarity(scale=1 + 0.25 * t),
                   "all": similarity(angle=-15 * t, scale=1 - 0.15 * t, tx=10 * t, ty=8 * t)}[kind])
    frames = [warp(picture, M) for M in Ms]
    truths = [moved(M) for M in Ms]
    tr = track(frames, truths[0])
    assert tr.lost_frames == []
    err = errors(tr, truths)
    assert err.max() < 1.0, err.max(axis=0)


def test_identity_transform_fails_the_check_when_content_moves(picture):
    """The truth used above is not trivially met: frames that do move differ from the first."""
    M = similarity(angle=20)
    tr = track([picture, warp(picture, M)], JOINTS)
    still = np.array(list(JOINTS.values()))
    got = np.array([tr.joints[n][1] for n in JOINTS])
    assert np.linalg.norm(got - still, axis=1).min() > 5


def test_blank_frames_are_lost_and_the_skeleton_held(picture):
    M = similarity(tx=6, ty=3)
    blank = np.full_like(picture, 255)
    frames = [picture, warp(picture, M), blank, blank, warp(picture, M @ np.vstack([similarity(tx=4), [0, 0, 1]]))]
    tr = track(frames, JOINTS)
    assert tr.lost_frames == [2, 3]
    assert "too few matches" in tr.reasons[2]
    held = tr.held()
    for n in JOINTS:
        assert np.isnan(tr.joints[n][2:4]).all()
        assert np.all(tr.confidence[n][2:4] == 0)
        assert np.array_equal(held[n][2], held[n][1]) and np.array_equal(held[n][3], held[n][1])
    # it picks up again when the picture comes back
    truth = moved(similarity(tx=10, ty=3))
    assert max(np.hypot(*(tr.joints[n][4] - truth[n])) for n in JOINTS) < 1.0
    js = tr.to_json(fps=12, size=(W, H))
    assert js["size"] == [W, H] and js["fps"] == 12
    assert js["joints"]["a"][2] is None and js["joints"]["a"][1] == pytest.approx(list(moved(M)["a"]), abs=1)
    assert len(js["confidence"]["a"]) == 5


def test_step_reports_lost_with_the_held_skeleton(picture):
    tk = Tracker(picture, JOINTS)
    s1 = tk.step(warp(picture, similarity(tx=5)))
    assert not s1.lost and s1.reason == ""
    s2 = tk.step(np.zeros_like(picture))
    assert s2.lost and s2.joints == s1.joints and all(c == 0 for c in s2.confidence.values())


def test_joint_leaving_the_frame_is_lost(picture):
    tk = Tracker(picture, {"a": JOINTS["a"], "c": JOINTS["c"]})
    st = tk.step(warp(picture, similarity(tx=-100)))
    assert st.lost and "a" in st.reason and "left the frame" in st.reason
    assert st.joints["a"] == JOINTS["a"]


def test_reanchor_follows_the_new_skeleton(picture):
    other = np.array(Image.open(os.path.join(ROOT, "assets", "kenney-character", "Sample.png")).convert("RGB"))
    other = cv2.resize(other[40:440, 560:880], (W, H), interpolation=cv2.INTER_AREA)  # the lone character
    tk = Tracker(picture, JOINTS)
    assert tk.step(other).lost  # nothing in common with the first picture
    anchor = {"a": (160.0, 60.0), "b": (160.0, 120.0), "e": (130.0, 200.0)}
    tk.reanchor(other, anchor)
    M = np.float64([[1, 0, 7], [0, 1, -4]])
    st = tk.step(cv2.warpAffine(other, M, (W, H), borderMode=cv2.BORDER_REPLICATE))
    assert not st.lost
    for n, (x, y) in anchor.items():
        assert np.hypot(st.joints[n][0] - x - 7, st.joints[n][1] - y + 4) < 1.0
    # joints not re-placed keep their last position as their anchor
    assert st.joints["f"] == pytest.approx((JOINTS["f"][0] + 7, JOINTS["f"][1] - 4), abs=1.0)
    with pytest.raises(KeyError):
        tk.reanchor(other, {"nope": (1.0, 2.0)})


def test_anchors_in_track(picture):
    M = similarity(tx=5)
    anchor = {"a": (100.0, 90.0)}
    tr = track([picture, warp(picture, M), picture, warp(picture, M)], JOINTS, anchors={2: anchor})
    assert tr.joints["a"][2] == pytest.approx(anchor["a"])
    assert tr.joints["a"][3] == pytest.approx((105.0, 90.0), abs=1.0)
    assert tr.joints["b"][3] == pytest.approx((JOINTS["b"][0] + 5, JOINTS["b"][1]), abs=1.0)


def test_mask_limits_the_key_points(picture):
    from puppet.video.features import Detector

    det = Detector(scale=1.0, dilate=4)
    mask = np.zeros((H, W), bool)
    mask[:, : W // 2] = True
    gray = cv2.cvtColor(picture, cv2.COLOR_RGB2GRAY)
    every, inside = det(gray), det(gray, mask)
    assert len(inside) > 10 and len(every) > len(inside)
    assert inside.pts[:, 0].max() <= W // 2 + 4
    assert len(det(gray, np.zeros((H, W), bool))) == 0


def test_mask_keeps_a_changing_background_out(picture):
    """Noise outside the character's mask changes every frame: the mask keeps it out."""
    rng = np.random.default_rng(1)
    mask = np.zeros((H, W), bool)
    mask[38:202, 40:280] = True
    frames, truths = [], []
    for t in range(4):
        M = similarity(tx=3 * t, ty=-2 * t)
        f = warp(picture, M)
        m = cv2.warpAffine(mask.astype(np.uint8), M, (W, H)) > 0
        f[~m] = rng.integers(0, 255, (int((~m).sum()), 3))
        frames.append(f)
        truths.append((moved(M), m))
    tr = track(frames, JOINTS, masks=[m for _, m in truths])
    assert tr.lost_frames == []
    err = errors(tr, [t for t, _ in truths])
    assert err.max() < 1.0, err.max(axis=0)
