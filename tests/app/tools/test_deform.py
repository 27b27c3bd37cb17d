"""The Deform panel and its canvas tools (issue 22) in a headless window: the mode
selectors, the stiffness brush and heat map, hinge and patch links, the link strength
slider, starch pins. Each checks the document, one undo step, and the solve or the
pixels."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key

from tests.app.harness import Driver, widget
from tests.conftest import bar_image as img
from tests.scene.test_fit_modes import distortion

pytestmark = pytest.mark.gl

SHOULDER = (80.0, 55.0)  # inside both the body and the arm


def arm_scene() -> dict:
    """A body (tall bar) and an arm (long bar, in front) overlapping at the shoulder
    (canvas x 60..100, y 40..70); pins: the body's foot and head, the arm's tip; pose 'up'
    lifts the tip about the shoulder."""
    return {"puppet": 1, "canvas": [300, 220], "background": [255, 255, 255, 255],
            "layers": [{"name": "body", "image": "body.png", "offset": [40, 20], "mesh": {"max_area": 60}},
                       {"name": "arm", "image": "arm.png", "offset": [50, 30], "mesh": {"max_area": 60}}],
            "pins": [{"name": "foot", "layer": "body", "at": [80, 190]},
                     {"name": "head", "layer": "body", "at": [80, 30]},
                     {"name": "tip", "layer": "arm", "at": [250, 55]}],
            "poses": {"up": {"tip": [80, -115]}}}  # the arm turned 90 degrees about the shoulder


@pytest.fixture
def arm_app(make_scene):
    path = make_scene(arm_scene(), {"body.png": img(80, 190, (10, 10, 70, 180), (200, 40, 40)),
                                    "arm.png": img(220, 50, (10, 10, 210, 40), (40, 40, 200))})
    d = Driver(path, size=(1100, 1000))  # tall: the Deform panel below the others
    d.click(*widget("header:Deform"))
    d.settle()
    yield d
    d.close()


def steps(d) -> int:
    return len(d.scene().history.undo_stack)


def layer(d, name):
    return next(r for r in d.scene().layers() if r.name == name)


def choose(d, key_, item):
    d.click(*widget(f"combo:{key_}"))
    d.frame(3)  # the popup opens, its items are drawn
    d.click(*widget(f"{key_}:{item}"))
    d.settle()


def drag_slider(d, label, a, b):
    """Drag slider ``label`` from fraction ``a`` to ``b`` of its noted rectangle (which
    holds the label right of the frame), settling at each step."""
    from puppet.app.ui.widgets import RECTS

    x0, y0, x1, y1 = RECTS[label]
    y = (y0 + y1) / 2
    d.press(x0 + a * (x1 - x0), y)
    for x in np.linspace(x0 + a * (x1 - x0), x0 + b * (x1 - x0), 5):
        d.drag(x, y)
        d.settle()
    d.release()
    d.settle()


def tool(d, label):
    d.click(*widget(f"deform-tool:{label}"))
    d.frame(2)


def test_mode_selectors_edit_the_scene_and_the_layer(arm_app):
    d = arm_app
    n = steps(d)
    choose(d, "scene mode", "similar")
    assert d.scene().data.deformer.mode == "similar" and steps(d) == n + 1
    d.click(*widget("layer:arm"))
    d.frame(2)
    choose(d, "layer mode", "distort")
    assert d.scene().to_dict()["layers"][1]["deformer"] == {"mode": "distort"} and steps(d) == n + 2
    choose(d, "layer mode", "scene default")
    assert "deformer" not in d.scene().to_dict()["layers"][1] and steps(d) == n + 3
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert d.scene().to_dict()["layers"][1]["deformer"] == {"mode": "distort"}


def test_a_mode_changes_the_pose(arm_app):
    from tests.scene.test_fit_modes import area_ratio

    d = arm_app
    d.app.edit(lambda s: s.add_pin("root", "arm", (70, 55)))
    d.app.edit(lambda s: s.set_target("tip", (180, 55), pose="up"))  # squeezed to 110 / 180
    d.app.edit(lambda s: s.set_active_pose("up"))
    d.settle()
    rigid = area_ratio([layer(d, "arm")])
    d.click(*widget("layer:arm"))
    d.frame(2)
    choose(d, "layer mode", "similar")
    similar = area_ratio([layer(d, "arm")])
    assert abs(similar - (110 / 180) ** 2) < 0.06 and rigid > similar + 0.15  # similar shrinks it evenly


def test_stiffness_brush_paints_one_step_and_stiffens_the_band(arm_app):
    d = arm_app
    d.app.edit(lambda s: s.add_pin("root", "arm", (70, 55)))
    d.app.edit(lambda s: s.set_target("tip", (230, 0), pose="up"))  # the arm bends up
    d.app.edit(lambda s: s.set_active_pose("up"))
    d.settle()

    def band_distortion():
        r = layer(d, "arm")
        cx = r.rest[r.triangles].mean(1)[:, 0]
        return distortion(r.rest, r.deformed, r.triangles, (cx > 140) & (cx < 190))

    soft = band_distortion()
    d.click(*widget("layer:arm"))
    tool(d, "brush")
    d.app.deform.brush = 60.0
    assert d.app.deform.value == 64  # the default strength, 25 %
    drag_slider(d, "slider:stiffness value", 0.25, 1.0)  # to 100 %, as a user drags it
    assert d.app.deform.value == 255
    n = steps(d)
    shown = layer(d, "arm")
    from puppet.app.model.pick import shown_point as shown_at

    # paint the band x 150..180 across the arm, where the posed arm shows it
    path = [d.screen_of(shown_at(shown, (x, 55.0))) for x in (150.0, 160.0, 170.0, 180.0)]
    d.drag_path(path)
    d.settle()
    assert steps(d) == n + 1, d.app.status.text
    L = d.scene().data.layers[1]
    assert L.stiffness is not None
    from puppet.imaging.io import load_rgba

    grey = load_rgba(L.stiffness)[..., 0]
    assert grey[25, 115] == 255 and grey[25, 20] == 0  # painted at canvas x 165, not at x 70
    assert band_distortion() < 0.5 * soft
    # the heat map (drawn while the brush is the tool, or View > Stiffness heat map): red over the band
    tool(d, "none")
    px0 = d.pixels()
    d.app.show_stiffness = True
    d.frame(3)
    px1 = d.pixels()
    x, y = map(int, d.screen_of(shown_at(layer(d, "arm"), (165.0, 55.0))))
    assert int(px1[y, x, 0]) - int(px1[y, x, 2]) > int(px0[y, x, 0]) - int(px0[y, x, 2]) + 40
    # Alt erases: back to no stiffness, one more step
    tool(d, "brush")
    d.drag_path(path, mods=key.MOD_ALT)
    d.settle()
    assert steps(d) == n + 2, (d.scene().data.links[0].strength, d.app.status.text)
    L = d.scene().data.layers[1]
    assert L.stiffness is None or load_rgba(L.stiffness)[25, 115, 0] == 0
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert load_rgba(d.scene().data.layers[1].stiffness)[25, 115, 0] == 255


def test_the_heat_map_drawn_last_does_not_crash_the_frame(arm_app):
    """A brush stroke, then H with the pointer over the panel: nothing is drawn over the
    canvas after the heat map, whose direct buffer copies must leave ImGui's draw list
    consistent (before: ``RuntimeError: IM_ASSERT(draw_list->VtxBuffer...)`` from
    ``imgui.render`` on the next frame)."""
    d = arm_app
    d.app.edit(lambda s: s.add_pin("root", "arm", (70, 55)))
    d.settle()
    d.click(*widget("layer:arm"))
    tool(d, "brush")
    d.app.deform.brush, d.app.deform.value = 40.0, 255  # the strongest red, to find it below
    path = [d.screen_of((x, 55.0)) for x in (150.0, 165.0, 180.0)]
    d.drag_path(path)
    d.settle()
    assert d.scene().data.layers[1].stiffness is not None
    d.move(*widget("deform-tool:brush"))  # over the panel: no brush cursor on the canvas
    before = d.pixels()
    d.key(key.H)
    d.frame(3)
    assert not d.app.show_pins
    x, y = map(int, d.screen_of((165.0, 55.0)))
    px = d.pixels()
    assert int(px[y, x, 0]) - int(px[y, x, 2]) > 40  # the heat map is still drawn, in red
    assert np.abs(px.astype(int) - before).max() > 0  # and the pins went


def test_hinge_keeps_the_body_still_where_a_segment_drags_it(arm_app):
    d = arm_app
    d.app.edit(lambda s: s.add_link("body", "arm", [[66, 50], [94, 60]]))
    d.app.edit(lambda s: s.set_active_pose("up"))
    d.settle()

    def body_moves():
        r = layer(d, "body")
        far = np.hypot(*(r.rest - SHOULDER).T) > 12
        return np.abs(r.deformed - r.rest)[far].max()

    seg = body_moves()
    d.app.edit(lambda s: s.remove_link("body", "arm"))
    d.app.edit(lambda s: s.set_active_pose("rest"))
    d.settle()
    tool(d, "hinge")
    n = steps(d)
    d.click(*d.screen_of(SHOULDER))
    d.settle()
    assert steps(d) == n + 1, d.app.status.text
    d.app.edit(lambda s: s.set_active_pose("up"))
    d.settle()
    link = d.scene().data.links[0]
    assert set(link.layers) == {"body", "arm"} and len(link.points) == 1 and not link.segments
    np.testing.assert_allclose(link.points[0], SHOULDER, atol=1.5)
    hinge = body_moves()
    assert hinge < 0.5 * seg and hinge <= 4.0  # (the body is held by two pins only)
    d.app.edit(lambda s: s.set_active_pose("rest"))
    d.settle()
    d.click(*d.screen_of(SHOULDER))  # hinged there already: refused (showing a pose was a step)
    d.settle()
    assert steps(d) == n + 3 and len(d.scene().data.links[0].points) == 1
    d.click(*d.screen_of((250, 200)))  # not in the overlap: refused
    d.settle()
    assert steps(d) == n + 3 and d.app.status.level == "error"


def test_patch_tool_closes_a_polygon_and_strength_slider(arm_app):
    d = arm_app
    tool(d, "patch")
    n = steps(d)
    corners = [(66, 44), (94, 44), (94, 66), (66, 66)]
    for c in corners:
        d.click(*d.screen_of(c))
    assert steps(d) == n and len(d.app.deform.draft) == 4
    d.click(*d.screen_of(corners[0]))  # the first point closes it
    d.settle()
    assert steps(d) == n + 1 and not d.app.deform.draft
    link = d.scene().data.links[0]
    np.testing.assert_allclose(link.polygons[0], corners, atol=1.0)
    # the strength slider of the selected link: a drag is one step
    d.frame(2)
    drag_slider(d, "slider:link strength", 0.6, 0.2)
    assert steps(d) == n + 2
    s = d.scene().data.links[0].strength
    assert 0.05 < s < 0.6


def test_starch_pins_are_added_in_pin_mode_and_never_dragged_in_pose_mode(arm_app):
    d = arm_app
    d.click(*widget("new pins are starch"))
    d.settle()
    assert d.app.pin_kind == "starch" and d.app.mode == "pin"
    d.click(*d.screen_of((200, 55)))
    d.settle()
    p = next(p for p in d.scene().data.pins if p.kind == "starch")
    assert p.layer == "arm" and d.app.selection == [p.name], (d.app.selection, p.name)
    d.frame(2)
    n = steps(d)
    drag_slider(d, "slider:starch radius", 0.3, 0.6)
    p = next(q for q in d.scene().data.pins if q.name == p.name)
    assert steps(d) == n + 1 and p.radius > 40
    # Pose mode: the marker rides on the posed mesh; a drag from it moves nothing, makes no pose
    d.app.set_mode("pose")
    d.app.edit(lambda s: s.set_target("tip", (230, 75), pose="up"))
    d.app.edit(lambda s: s.set_active_pose("up"))
    d.settle()
    m = d.app.marker(p.name)
    np.testing.assert_allclose(m.xy, np.add(p.at, (-20, 20)), atol=0.5)  # the arm moved with its tip
    poses = dict(d.scene().to_dict().get("poses", {}))
    xy = d.pin_screen(p.name)
    d.press(*xy)
    assert "starch pin" in d.app.status.text  # told why nothing follows the pointer
    for k in (1, 2):
        d.drag(xy[0] + 40 * k, xy[1] + 30 * k)
    d.release()
    d.settle()
    assert d.scene().to_dict().get("poses", {}) == poses
    np.testing.assert_allclose(d.app.marker(p.name).xy, m.xy)
    assert d.app.status.level != "error", d.app.status.text  # not offered as a drag at all
