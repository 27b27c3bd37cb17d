"""Clipping a link segment twice changes nothing: the app's link pencil stores the part
that :func:`puppet.scene.rig.links.clip_segment` keeps, and a scene holding that part builds
and renders exactly as one holding the segment as drawn (what the engine does with old
scenes is unchanged)."""
from __future__ import annotations

import numpy as np
import pytest
import puppet
from puppet.scene.rig.links import clip_masks, clip_segment
from tests.scene.test_fit_modes import arm_images, arm_scene


class Im:
    """What :func:`clip_masks` reads of a built image."""

    def __init__(self, mask, offset):
        self.mask, self.offset = mask, offset


def masks_of(*ims):
    return clip_masks(ims)


def test_a_clipped_segment_is_kept_as_it_is_by_hand():
    a = np.zeros((20, 30), bool)
    a[5:15, 2:20] = True  # canvas x 2..20, y 5..15
    b = np.ones((10, 10), bool)  # canvas x 10..20, y 3..13
    masks = masks_of(Im(a, (0.0, 0.0)), Im(b, (10.0, 3.0)))
    c = clip_segment(np.array([[12.0, 8.0], [28.0, 8.0]]), masks)
    # samples every 0.25 px: inside both from x 12 to 19.75 (column 19), ends pulled in by 0.5
    np.testing.assert_allclose(c, [[12.5, 8.0], [19.25, 8.0]], atol=1e-12)
    again = clip_segment(c, masks)
    assert again is c  # inside (with the 1 px tolerance): the segment itself, no note
    assert clip_segment(np.array([[3.0, 8.0], [8.0, 8.0]]), masks) is None  # on a only


def test_clipping_is_idempotent_on_random_segments():
    rng = np.random.default_rng(5)
    yy, xx = np.mgrid[0:80, 0:90]
    disc = (xx - 40) ** 2 + (yy - 40) ** 2 < 30 ** 2
    blob = ((xx - 30) ** 2 / 900 + (yy - 25) ** 2 / 300 < 1) | ((xx > 50) & (yy > 30) & (yy < 45))
    masks = masks_of(Im(disc, (0.0, 0.0)), Im(blob, (7.0, 12.0)))
    kept = 0
    for _ in range(300):
        seg = rng.uniform(-10, 110, (2, 2))
        c = clip_segment(seg, masks)
        if c is None or c is seg:
            continue
        kept += 1
        assert clip_segment(c, masks) is c, seg
    assert kept > 50


@pytest.mark.gl
def test_the_clipped_part_builds_and_renders_as_the_drawn_segment(make_scene):
    drawn = np.array([[150.0, 125.0], [215.0, 125.0]])  # leaves the arm at x 180
    a = puppet.load_scene(make_scene(arm_scene(segments=[drawn.tolist()]), arm_images(), name="a.json"))
    ims = a.built.images
    c = clip_segment(drawn, masks_of(*ims))
    assert c is not drawn and c[0][0] > 180
    b = puppet.load_scene(make_scene(arm_scene(segments=[c.tolist()]), arm_images(), name="b.json"))
    assert a.built.notes and not b.built.notes  # the stored clipped part needs no clipping
    for ra, rb in zip(a.layers(pose="up"), b.layers(pose="up")):
        np.testing.assert_array_equal(ra.rest, rb.rest)
        np.testing.assert_array_equal(ra.triangles, rb.triangles)
        np.testing.assert_array_equal(ra.deformed, rb.deformed)
    np.testing.assert_array_equal(a.render(pose="up"), b.render(pose="up"))
    a.close()
    b.close()
