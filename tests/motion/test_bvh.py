"""The BVH reader: rotation orders, channel subsets, end sites, positions on any joint, many
joints; forward kinematics against hand-computed positions; bad files in one line."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest

from puppet.errors import SceneError
from puppet.motion.bvh import parse_bvh, rotation_matrices
from tests.conftest import ASSETS


def _bvh(hierarchy: str, rows: list[str], dt: float = 0.04) -> str:
    return f"HIERARCHY\n{hierarchy}\nMOTION\nFrames: {len(rows)}\nFrame Time: {dt}\n" + "\n".join(rows) + "\n"


ARM = """ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition {order}
  JOINT Arm
  {{
    OFFSET 10 0 0
    CHANNELS 3 {order}
    End Site
    {{
      OFFSET 0 5 0
    }}
  }}
}}"""


def _arm(order: str) -> str:
    return ARM.replace("{order}", order).replace("{{", "{").replace("}}", "}")


def test_a_root_and_a_joint_pose_as_computed_by_hand_in_three_rotation_orders():
    # the root turns 90 degrees about Z, the arm 90 about Y: the order decides where the tip goes
    for order in ("Zrotation Xrotation Yrotation", "Xrotation Yrotation Zrotation", "Yrotation Xrotation Zrotation"):
        vals = {"Z": 90.0, "X": 0.0, "Y": 0.0}
        arm = {"Z": 0.0, "X": 0.0, "Y": 90.0}
        names = [w[0] for w in order.split()]
        row = "1 2 3 " + " ".join(str(vals[a]) for a in names) + " " + " ".join(str(arm[a]) for a in names)
        m = parse_bvh(_bvh(_arm(order), [row]))
        assert m.names == ["Hips", "Arm", "Arm_end"] and m.joints[2].end and m.joints[2].channels == ()
        P = m.positions()[0]
        # Rz(90) takes x to y: the arm sits at (1, 2 + 10, 3); Rz(90) Ry(90) takes (0, 5, 0) to (-5, 0, 0)
        np.testing.assert_allclose(P, [[1, 2, 3], [1, 12, 3], [-4, 12, 3]], atol=1e-12)


def test_the_order_of_the_channels_is_the_order_of_the_product():
    # two rotations that do not commute: X 90 then Y 90 against Y 90 then X 90, on the tip (0, 5, 0)
    a = parse_bvh(_bvh(_arm("Xrotation Yrotation Zrotation"), ["0 0 0 0 0 0 90 90 0"])).positions()[0, 2]
    b = parse_bvh(_bvh(_arm("Yrotation Xrotation Zrotation"), ["0 0 0 0 0 0 90 90 0"])).positions()[0, 2]
    # Rx(90) Ry(90) (0,5,0) = Rx(90) (0,5,0) = (0,0,5); Ry(90) Rx(90) (0,5,0) = Ry(90) (0,0,5) = (5,0,0)
    np.testing.assert_allclose(a - [10, 0, 0], [0, 0, 5], atol=1e-12)
    np.testing.assert_allclose(b - [10, 0, 0], [5, 0, 0], atol=1e-12)


def test_rotation_matrices_are_right_handed():
    for axis, v, w in (("X", [0, 1, 0], [0, 0, 1]), ("Y", [0, 0, 1], [1, 0, 0]), ("Z", [1, 0, 0], [0, 1, 0])):
        np.testing.assert_allclose(rotation_matrices(axis, np.array([90.0]))[0] @ v, w, atol=1e-12)


def test_channel_subsets_and_positions_on_a_child_replace_its_offset_on_their_axes():
    text = _bvh("""ROOT r
{
  OFFSET 5 6 7
  CHANNELS 2 Yposition Zrotation
  JOINT c
  {
    OFFSET 1 2 3
    CHANNELS 2 Xposition Xrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}""", ["10 0 4 90", "20 90 0 0"])
    m = parse_bvh(text)
    P = m.positions()
    # frame 0: root at (5, 10, 7); c's x from its channel: (4, 2, 3); tip (0, 1, 0) turned 90 about x -> (0, 0, 1)
    np.testing.assert_allclose(P[0], [[5, 10, 7], [9, 12, 10], [9, 12, 11]], atol=1e-12)
    # frame 1: root at (5, 20, 7) turned 90 about z: c's (0, 2, 3) -> (-2, 0, 3); tip (0, 1, 0) -> (-1, 0, 0)
    np.testing.assert_allclose(P[1], [[5, 20, 7], [3, 20, 10], [2, 20, 10]], atol=1e-12)
    # the rest: channels at zero, positions at the offsets
    np.testing.assert_allclose(m.rest(), [[5, 6, 7], [6, 8, 10], [6, 9, 10]], atol=1e-12)
    np.testing.assert_allclose(m.times, [0, 0.04])


def test_many_joints_in_a_chain_and_several_roots_and_end_sites():
    n = 60
    body = "".join(f"JOINT j{i}\n{{\nOFFSET 1 0 0\nCHANNELS 1 Zrotation\n" for i in range(1, n))
    body += "End Site\n{\nOFFSET 1 0 0\n}\n" + "}\n" * (n - 1)
    text = (f"HIERARCHY\nROOT j0\n{{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n{body}}}\n"
            "ROOT other\n{\nOFFSET 0 -3 0\nCHANNELS 0\nEnd Site\n{\nOFFSET 0 -1 0\n}\nEnd Site\n{\nOFFSET 2 0 0\n}\n}\n"
            f"MOTION\nFrames: 1\nFrame Time: 0.01\n" + " ".join(["6"] * n) + "\n")
    m = parse_bvh(text)
    assert len(m.joints) == n + 1 + 3 and m.names[-2:] == ["other_end", "other_end2"]
    P = m.positions()[0]
    # each joint turns 6 degrees more: joint k sits at the sum of unit steps at angles 6, 12, ... 6k
    ang = np.radians(6 * np.arange(1, n + 1))
    expect = np.concatenate([[[0, 0]], np.cumsum(np.stack([np.cos(ang), np.sin(ang)], 1), axis=0)])
    np.testing.assert_allclose(P[:n + 1, :2], expect, atol=1e-9)
    np.testing.assert_allclose(P[n + 1:], [[0, -3, 0], [0, -4, 0], [2, -3, 0]], atol=1e-12)
    assert m.joints[n + 1].parent == -1 and m.joints[n + 2].parent == n + 1


def test_forward_kinematics_is_vectorised_over_frames():
    rng = np.random.default_rng(1)
    rows = [" ".join(f"{v:.6f}" for v in rng.uniform(-90, 90, 9)) for _ in range(7)]
    m = parse_bvh(_bvh(_arm("Zrotation Xrotation Yrotation"), rows))
    P = m.positions()
    for f in range(7):
        np.testing.assert_allclose(m.positions(slice(f, f + 1))[0], P[f], atol=1e-12)
    # bone lengths are kept
    assert np.allclose(np.linalg.norm(P[:, 1] - P[:, 0], axis=1), 10)
    assert np.allclose(np.linalg.norm(P[:, 2] - P[:, 1], axis=1), 5)


@pytest.mark.parametrize("text, where", [
    ("HIERARCH\n", "line 1: 'HIERARCHY' expected"),
    (_bvh(_arm("Zrotation Xrotation Yrotation"), ["1 2 3"]), "line 19: 3 values, 9 channels declared"),
    (_bvh(_arm("Zrotation Xrotation Yrotation"), ["1 2 3 4 5 6 7 8 x"]), "line 19: 'x' is not a number"),
    (_bvh(_arm("Zrotation Xrotation Wrotation"), ["0"]), "line 5: unknown channel 'Wrotation'"),
    (_bvh(_arm("Zrotation Xrotation Yrotation"), []).replace("Frames: 0", "Frames: 2"), "Frames: 2 declared, 0 rows"),
    (_bvh(_arm("Zrotation Xrotation Yrotation"), ["0 " * 9]).replace("Frame Time: 0.04", "Frame Time: 0"),
     "line 18: Frame Time: 0 is not a positive"),
    ("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n", "line 4: the file ends where an OFFSET value was expected"),
    ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nJOINT a\n{\nOFFSET 0 0 0\n}\n}\nMOTION\nFrames: 0\nFrame Time: 1\n",
     "line 5: joint 'a' is named twice"),
    ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nEnd Site\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\n}\n",
     "line 8: an End Site has no CHANNELS"),
])
def test_bad_files_are_refused_in_one_line_naming_the_file_and_line(text, where):
    with pytest.raises(SceneError) as e:
        parse_bvh(text, file="clip.bvh")
    msg = str(e.value)
    assert msg.startswith("clip.bvh: ") and where in msg and "\n" not in msg, msg


def test_a_file_with_no_frames_reads():
    m = parse_bvh(_bvh(_arm("Zrotation Xrotation Yrotation"), []))
    assert m.count == 0 and m.positions().shape == (0, 3, 3) and math.isclose(m.frame_time, 0.04)


def test_a_broken_file_is_read_or_refused_in_one_line_never_anything_else():
    """Bytes cut, words dropped or doubled anywhere in a real clip: a Motion or one SceneError line."""
    path = os.path.join(ASSETS, "motion", "jumping_jacks.bvh")
    text = open(path, encoding="utf-8").read()
    head = text[:text.index("MOTION") + 200]
    rng = np.random.default_rng(7)
    words = head.split(" ")
    for _ in range(300):
        k = int(rng.integers(len(words)))
        middle = ([], [words[k], words[k]], ["?"])[int(rng.integers(3))]  # dropped, doubled, replaced
        w = words[:k] + middle + words[k + 1:]
        cut = " ".join(w) if rng.random() < 0.5 else head[:int(rng.integers(len(head)))]
        try:
            parse_bvh(cut, file="x.bvh")
        except SceneError as e:
            assert str(e).startswith("x.bvh: line ") and "\n" not in str(e)
