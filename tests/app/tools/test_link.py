"""The Link step's pencil in a headless window: a segment that leaves the overlap of the
two layers is previewed, while it drags, as the build will clip it (the kept part solid,
the dropped parts dashed), and the release stores exactly that kept part (one undo
step); a segment with nothing in the overlap is refused and the scene is unchanged."""
from __future__ import annotations

import time

import numpy as np
import pytest
from pyglet.window import key

from puppet.app.tools import link as linkpencil
from puppet.app.ui.overlay import LINK
from puppet.scene.rig.links import clip_masks, clip_segment, link_parts
from tests.app.harness import Driver, widget
from tests.conftest import bar_image as img

pytestmark = pytest.mark.gl

#: the arm (canvas x 60..160, y 30..70) lies on the body (x 20..180, y 20..80)
LEAVING = [(100.0, 50.0), (196.0, 50.0)]  # leaves the arm at x 160 (and the body, the canvas)
INSIDE = [(70.0, 40.0), (150.0, 60.0)]
OUTSIDE = [(30.0, 25.0), (50.0, 75.0)]  # on the body only


@pytest.fixture
def link_app(make_scene):
    scene = {"puppet": 1, "canvas": [200, 100], "background": [255, 255, 255, 255],
             "layers": [{"name": "body", "image": "body.png"},
                        {"name": "arm", "image": "arm.png", "offset": [60, 30]}]}
    path = make_scene(scene, {"body.png": img(200, 100, (20, 20, 180, 80), (200, 40, 40)),
                              "arm.png": img(100, 40, (0, 0, 100, 40), (40, 40, 200))})
    d = Driver(path)
    d.click(*widget("step:link"))
    d.settle()
    assert d.app.script.step == "link" and d.app.script.link_pair(d.app) == ("body", "arm")
    yield d
    d.close()


def engine_clip(d, seg):
    """``seg`` clipped as the build clips it, from the scene's own images."""
    ims = d.scene().built.images
    return clip_segment(np.asarray(seg, float), clip_masks(ims))


def undo_steps(d) -> int:
    return len(d.scene().history.undo_stack)


def colour_at(d, xy):
    x, y = d.screen_of(xy)
    return d.pixels()[int(round(y)), int(round(x))].astype(int)


def test_a_segment_leaving_the_overlap_stores_the_part_the_build_keeps(link_app):
    d, sc = link_app, link_app.app.script
    before = undo_steps(d)
    d.press(*d.screen_of(LEAVING[0]))
    d.drag(*d.screen_of((140.0, 50.0)))  # still inside: all of it kept, nothing dropped
    p = sc.link_preview
    assert p.kept is not None and not p.dropped() and np.allclose(p.kept, [p.p0, p.p1])
    assert d.app.status.text == f"link body and arm: {p.length:.0f} px, all where body and arm overlap"
    d.drag(*d.screen_of(LEAVING[1]))
    p = sc.link_preview  # live: what the build would keep of the segment as it is now
    want = engine_clip(d, [p.p0, p.p1])
    np.testing.assert_array_equal(p.kept, want)
    assert 159 < p.kept[1][0] < 160 and abs(p.kept[0][0] - 100) < 1 and len(p.dropped()) == 1
    assert d.app.status.text == (f"link keeps {p.kept_length:.0f} of {p.length:.0f} px: the dashed part "
                                 "lies outside where body and arm overlap")  # live, in the status line
    green = np.array([round(c * 255) for c in LINK[:3]])
    assert np.abs(colour_at(d, (130.0, 50.0)) - green).max() <= 2  # the kept part, drawn as a link
    drop = p.dropped()[0]
    u = (drop[1] - drop[0]) / np.hypot(*(drop[1] - drop[0])) / d.app.view.scale  # one window px along
    on, off = linkpencil.DASH
    assert colour_at(d, drop[0] + 5.0 * u).min() > 170  # on the first dash (past the kept end's dot): whitish
    assert colour_at(d, drop[0] + (on + off / 2) * u).min() < 100  # in the gap: the red body
    assert not d.scene().data.links and undo_steps(d) == before  # nothing stored while dragging
    d.release(*d.screen_of(LEAVING[1]))
    d.settle()
    links = d.scene().data.links
    assert len(links) == 1 and set(links[0].layers) == {"body", "arm"}
    np.testing.assert_array_equal(links[0].segments[0], want)  # exactly the clipped part
    assert undo_steps(d) == before + 1
    status = d.app.status
    assert status.level == "info" and f"link kept {np.hypot(*(want[1] - want[0])):.0f} of " \
        f"{p.length:.0f} px" in status.text and "body and arm overlap" in status.text, status.text
    # the build uses the stored segment as it is: no further clipping, no note
    parts = link_parts(d.scene().data, d.scene().built.images)
    assert not parts.notes and len(parts.segments) == 1
    np.testing.assert_array_equal(parts.segments[0][2], want)
    # one undo step takes it away, and with it the dashed dropped part
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert not d.scene().data.links and undo_steps(d) == before
    assert not linkpencil.stored(d.app, sc.link_preview)


def test_the_kept_part_stays_drawn_until_the_scene_shows_the_link(link_app):
    d = link_app
    d.press(*d.screen_of(LEAVING[0]))
    d.drag(*d.screen_of(LEAVING[1]))
    d.app.edit(lambda s: time.sleep(1.0))  # the scene thread busy: the link's edit waits
    d.release(*d.screen_of(LEAVING[1]))
    d.frame(2)
    assert not d.app.snap.data.links and d.app.snap.done < d.app.script.link_preview.job
    green = np.array([round(c * 255) for c in LINK[:3]])
    assert np.abs(colour_at(d, (130.0, 50.0)) - green).max() <= 2  # still drawn, not blinking away
    d.settle()
    assert len(d.app.snap.data.links) == 1
    assert np.abs(colour_at(d, (130.0, 50.0)) - green).max() <= 2  # now the link itself


def test_a_segment_inside_the_overlap_is_stored_as_drawn(link_app):
    d = link_app
    d.drag_path([d.screen_of(INSIDE[0]), d.screen_of(INSIDE[1])])
    d.settle()
    p = d.app.script.link_preview
    seg = d.scene().data.links[0].segments[0]
    np.testing.assert_array_equal(seg, [p.p0, p.p1])
    np.testing.assert_allclose(seg, INSIDE, atol=0.5)
    assert d.app.status.text == f"link body and arm: {p.length:.0f} px"


def test_a_segment_outside_the_overlap_is_refused_and_changes_nothing(link_app):
    d = link_app
    doc, before = d.scene().to_dict(), undo_steps(d)
    d.press(*d.screen_of(OUTSIDE[0]))
    d.drag(*d.screen_of(OUTSIDE[1]))
    p = d.app.script.link_preview
    assert p.kept is None and len(p.dropped()) == 1  # all of it shown as dropped while it drags
    assert d.app.status.text.endswith("it would not be added")
    d.release(*d.screen_of(OUTSIDE[1]))
    d.settle()
    assert d.scene().to_dict() == doc and undo_steps(d) == before
    assert d.app.status.level == "error"
    assert "no part of the segment lies where body and arm overlap" in d.app.status.text
    u = (p.p1 - p.p0) / p.length / d.app.view.scale  # one window px along
    assert colour_at(d, p.p0 + 3.0 * u).min() > 170  # the refused segment stays, dashed white
    r, g, b = colour_at(d, (p.p0 + p.p1) / 2 + np.array([3.0, 3.0]) / d.app.view.scale)
    assert r > 230 and g < 100 and b < 100  # with a red cross at its middle (on a red body: brighter)
    assert engine_clip(d, OUTSIDE) is None  # the build would refuse it too
    d.drag_path([d.screen_of(INSIDE[0]), d.screen_of(INSIDE[1])])  # a link, then a refusal, then undo
    d.settle()
    d.drag_path([d.screen_of(OUTSIDE[0]), d.screen_of(OUTSIDE[1])])
    d.settle()
    assert colour_at(d, p.p0 + 3.0 * u).min() > 170
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert not d.scene().data.links
    assert colour_at(d, p.p0 + 3.0 * u).max() < 220  # the refusal is old news: not drawn any more


def test_escape_during_the_drag_draws_and_adds_nothing(link_app):
    d = link_app
    before = undo_steps(d)
    d.press(*d.screen_of(LEAVING[0]))
    d.drag(*d.screen_of(LEAVING[1]))
    assert d.app.script.link_preview is not None
    d.key(key.ESCAPE)
    d.release(*d.screen_of(LEAVING[1]))
    d.settle()
    assert d.app.script.link_preview is None and not d.scene().data.links and undo_steps(d) == before
    assert d.app.status.text == "drag cancelled"


def test_dropped_parts_by_hand():
    P = linkpencil.Preview
    p = P(np.array([0.0, 0.0]), np.array([10.0, 0.0]), np.array([[2.0, 0.0], [7.0, 0.0]]), ("a", "b"))
    d = p.dropped()
    assert len(d) == 2 and np.allclose(d[0], [[0, 0], [2, 0]]) and np.allclose(d[1], [[7, 0], [10, 0]])
    assert p.kept_length == 5.0 and p.length == 10.0
    assert linkpencil.message(p) == "link keeps 5 of 10 px: the dashed part lies outside where a and b overlap"
    p.done = True
    assert linkpencil.message(p) == "link kept 5 of 10 px: the rest lies outside where a and b overlap"
    # the half pixel the build pulls an inside end in by is not a dropped part
    p = P(np.array([0.0, 0.0]), np.array([10.0, 0.0]), np.array([[9.5, 0.0], [0.5, 0.0]]), ("a", "b"))
    p.done = True
    assert p.dropped() == [] and linkpencil.message(p) == "link a and b: 9 px"
    p = P(np.array([0.0, 0.0]), np.array([0.0, 4.0]), None, ("a", "b"))
    assert len(p.dropped()) == 1 and np.allclose(p.dropped()[0], [[0, 0], [0, 4]])
    assert linkpencil.message(p).endswith("it would not be added")
    p.done = True
    assert linkpencil.message(p).startswith("no part of the segment lies where a and b overlap")
