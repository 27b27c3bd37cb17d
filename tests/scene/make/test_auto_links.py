"""Proposed links (``--links auto``) on hand-checked overlaps."""
import numpy as np

from puppet.imaging.layered import ArtLayer
from puppet.scene.make.anatomy import propose_rig
from puppet.scene.make.auto_links import link_segment


def rect(name, x0, y0, x1, y1):
    a = np.zeros((y1 - y0, x1 - x0, 4), np.uint8)
    a[..., 3] = 255
    return ArtLayer(name, a, (x0, y0))


def test_segment_crosses_the_part_at_its_end_inside_the_other():
    body = rect("body", 0, 0, 200, 60)
    arm = rect("arm", 40, 30, 60, 150)  # its top 30 rows lie over the body
    (p, q), part, area = link_segment(body, arm)
    assert part == "arm" and area == 20 * 30
    centre = (np.array(p) + np.array(q)) / 2
    # deepest-enough point farthest from the arm's free pixels (y >= 60): near the top of the overlap
    assert abs(centre[0] - 50) <= 1 and 34 <= centre[1] <= 37
    assert abs(p[1] - q[1]) < 1e-6 and 3 <= abs(p[0] - q[0]) <= 12  # across the arm
    for x, y in (p, q):
        assert 40 < x < 60 and 30 < y < 60  # inside both


def test_no_link_without_a_real_overlap():
    assert link_segment(rect("a", 0, 0, 10, 10), rect("b", 20, 0, 30, 10)) is None
    assert link_segment(rect("a", 0, 0, 10, 10), rect("b", 8, 0, 30, 10)) is None  # 2 px thin


def test_links_form_a_tree_and_skip_the_backdrop():
    back = rect("backdrop", 0, 0, 300, 300)
    body = rect("body", 100, 100, 200, 200)
    head = rect("head", 120, 60, 180, 120)  # over the body
    arm = rect("arm", 150, 110, 260, 130)  # over the body and the head
    rig = propose_rig([back, body, head, arm], canvas=(300, 300))
    assert {frozenset(k["layers"]) for k in rig.links} == {frozenset(("body", "head")), frozenset(("body", "arm"))}
    assert rig.roots == ["body"] and "backdrop" not in {p["layer"] for p in rig.pins}
    # head and arm already linked by the scene: they count as one part, joined to the body once
    rig = propose_rig([back, body, head, arm], canvas=(300, 300), skip={frozenset(("head", "arm"))})
    assert len(rig.links) == 1 and "body" in rig.links[0]["layers"]
