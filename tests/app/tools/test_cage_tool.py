"""The Deform panel's cage tool (issue 33) in a headless window, through the app's own
controls: Make cage, a vertex dragged, added on an edge, deleted (right click, Delete), a
refused edit, the coordinates, Remove cage, each one undo step; the cage drawn; and in
Pose mode a cage handle dragged like a pin."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key, mouse

from puppet.app.tools import deform as deformtools
from puppet.app.ui.actions import ACTIONS
from puppet.app.ui.deform_overlay import CAGE
from puppet.app.ui.widgets import RECTS
from puppet.deform.cage import check_cage
from tests.app.harness import Driver, widget
from tests.conftest import bar_image

pytestmark = pytest.mark.gl

BOX = (70, 50, 170, 70)  # the bar's opaque pixels on the canvas (x0, y0, x1, y1)


def caged_scene(cage=None) -> dict:
    layer = {"name": "bar", "image": "bar.png", "offset": [60, 40]}
    if cage is not None:
        layer["cage"] = cage
    return {"puppet": 1, "canvas": [240, 120], "background": [255, 255, 255, 255], "layers": [layer],
            "pins": [], "poses": {"p": {}}}


@pytest.fixture
def open_app(make_scene):
    made = []

    def open_(cage=None):
        d = Driver(make_scene(caged_scene(cage), {"bar.png": bar_image()}), size=(1100, 1000))
        made.append(d)
        return d
    yield open_
    for d in made:
        d.close()


def steps(d) -> int:
    return len(d.scene().history.undo_stack)


def cage(d):
    return d.scene().data.layers[0].cage


def vertex(d, j):
    return d.screen_of(d.app.snap.layers[0].exterior[f"bar:cage{j}"])


def colour_near(d, p, r=3, colour=CAGE) -> bool:
    """Some pixel within ``r`` of window point ``p`` has the cage's colour (or ``colour``)."""
    x, y = int(round(p[0])), int(round(p[1]))
    patch = d.pixels()[y - r:y + r + 1, x - r:x + r + 1].astype(int)
    want = np.rint(np.array(colour[:3]) * 255)
    return bool((np.abs(patch - want).max(axis=2) <= 12).any())


def test_cage_tool_makes_edits_and_removes_a_cage(open_app):
    d = open_app()
    d.key(key._1)  # Pin mode
    d.click(*widget("layer:bar"))  # the Layers panel's selection
    d.settle()
    d.click(*widget("header:Deform"))
    d.settle()
    assert d.app.selected_layer == "bar"
    d.click(*widget("deform-tool:cage"))
    d.frame(2)
    d.click(*widget("input:cage vertices"))
    d.key(key.A, key.MOD_CTRL)
    d.type("6")
    d.key(key.ENTER)
    d.click(*widget("Make cage"))
    d.settle()
    c, n0 = cage(d), steps(d)
    assert c is not None and c.auto == 6 and c.offset == 10.0 and c.coordinates == "green"
    ext = d.app.snap.layers[0].exterior
    m = sum(1 for k in ext if k.startswith("bar:cage"))
    assert 3 <= m <= 8
    C = np.array([ext[f"bar:cage{j}"] for j in range(m)])
    assert (C.min(0) < [BOX[0], BOX[1]]).all() and (C.max(0) > [BOX[2], BOX[3]]).all()  # round the bar
    d.frame(2)
    assert colour_near(d, vertex(d, 0))  # drawn while the tool is on

    # drag vertex 0 away from the bar by 12 window px: one step, the rest cage moved there
    p0 = vertex(d, 0)
    out = np.sign(C[0] - C.mean(0)) * 12
    d.drag_path([p0, (p0[0] + out[0] / 2, p0[1] + out[1] / 2), (p0[0] + out[0], p0[1] + out[1])])
    d.settle()
    P = np.asarray(cage(d).points)
    assert steps(d) == n0 + 1 and len(P) == m
    np.testing.assert_allclose(P[0], C[0] + out / d.app.view.scale, atol=1e-6)
    np.testing.assert_array_equal(P[1:], C[1:])
    assert cage(d).auto == 6  # it says how the cage was made

    # a click on the middle of edge 1-2 adds a vertex there; a key's target of vertex 2 follows it
    d.app.edit(lambda s: s.key_pins(0.0, {"bar:cage2": [float(x) + 3 for x in P[2]]}))
    d.settle()
    n0 += 1
    a, b = vertex(d, 1), vertex(d, 2)
    d.click((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
    d.settle()
    Q = np.asarray(cage(d).points)
    assert steps(d) == n0 + 2 and len(Q) == m + 1
    assert list(d.scene().to_dict()["animation"]["keys"][0]["pins"]) == ["bar:cage3"]
    e = P[2] - P[1]  # on the edge (projected there), within a window pixel of the click
    assert abs(e[0] * (Q[2] - P[1])[1] - e[1] * (Q[2] - P[1])[0]) / np.hypot(*e) < 1e-6
    assert np.hypot(*(Q[2] - (P[1] + P[2]) / 2)) <= 1.0 / d.app.view.scale
    np.testing.assert_array_equal(np.delete(Q, 2, axis=0), P)

    # a right click deletes it again; Delete deletes the selected vertex
    d.click(*vertex(d, 2), button=mouse.RIGHT)
    d.settle()
    np.testing.assert_array_equal(cage(d).points, P)
    assert steps(d) == n0 + 3
    assert list(d.scene().to_dict()["animation"]["keys"][0]["pins"]) == ["bar:cage2"]
    d.click((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)  # added again, selected
    d.settle()
    assert d.app.selection == ["bar:cage2"] and len(cage(d).points) == m + 1
    assert colour_near(d, vertex(d, 2), colour=(1.0, 0.2, 0.15))  # a selected vertex is red
    d.key(key.DELETE)
    d.settle()
    np.testing.assert_array_equal(cage(d).points, P)
    assert steps(d) == n0 + 5

    # a vertex dragged onto the bar's middle: refused in one line, the cage as it was
    before = np.asarray(cage(d).points).copy()
    p0 = vertex(d, 0)
    mid = d.screen_of(((BOX[0] + BOX[2]) / 2, (BOX[1] + BOX[3]) / 2))
    d.drag_path([p0, ((p0[0] + mid[0]) / 2, (p0[1] + mid[1]) / 2), mid])
    d.settle()
    assert d.app.status.level == "error" and "layers[0].cage" in d.app.status.text
    assert "\n" not in d.app.status.text
    np.testing.assert_array_equal(cage(d).points, before)
    assert steps(d) == n0 + 5
    assert d.app.snap.layers[0].exterior["bar:cage0"] == pytest.approx(tuple(before[0]))
    assert deformtools.cage_preview(d.app) is None  # the dragged cage is no longer drawn

    # the coordinates: one step, the points kept; undo gives green back
    d.click(*widget("combo:cage coordinates"))
    d.frame(3)
    d.click(*widget("cage coordinates:mvc"))
    d.settle()
    assert cage(d).coordinates == "mvc" and steps(d) == n0 + 6
    np.testing.assert_array_equal(cage(d).points, before)
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert cage(d).coordinates == "green"

    # Remove cage; the View toggle draws a cage with the tool off
    d.click(*widget("Remove cage"))
    d.settle()
    assert cage(d) is None and not any(k.startswith("bar:cage") for k in d.app.snap.layers[0].exterior)
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    d.click(*widget("deform-tool:none"))
    d.frame(2)
    v = vertex(d, 0)
    assert not colour_near(d, v)
    next(a for a in ACTIONS if a.name == "cages").run(d.app, d.w)  # View > Cages
    d.frame(2)
    assert colour_near(d, v)


def test_pose_mode_drags_a_cage_handle_like_a_pin(open_app):
    d = open_app({"points": [[50, 30], [190, 30], [190, 90], [50, 90]], "coordinates": "mvc"})
    d.app.edit(lambda s: s.set_active_pose("p"))
    d.click(*widget("header:Deform"))
    d.settle()
    d.click(*widget("deform-tool:cage"))  # on in Pose mode: the cage drawn, drags as pins do
    d.frame(2)
    assert deformtools.state(d.app).tool == "cage"
    n0 = steps(d)
    rest = np.array(d.app.snap.layers[0].deformed)
    start = d.pin_screen("bar:cage2")
    d.press(*start)
    previews = 0
    for k in range(1, 5):
        d.drag(start[0] + 5 * k, start[1] + 5 * k)
        d.settle()
        previews += d.app.snap.preview
    assert colour_near(d, (start[0] + 20, start[1] + 20), colour=(1.0, 0.2, 0.15))  # where the pointer is
    d.release()
    d.settle()
    assert previews > 0 and steps(d) == n0 + 1
    to = np.array([190, 90]) + 20 / d.app.view.scale
    r = d.app.snap.layers[0]
    np.testing.assert_allclose(r.exterior["bar:cage2"], to, atol=1e-6)
    # the cage map: the vertex nearest the moved corner moved most, the far corner stayed
    V = np.asarray(r.rest)
    far, near = np.argmin(np.hypot(*(V - [70, 50]).T)), np.argmin(np.hypot(*(V - [170, 70]).T))
    moved = np.hypot(*(np.asarray(r.deformed) - rest).T)
    assert moved[near] > 3 and moved[far] < moved[near] / 3

    # green landmarks asked for a change of proportions: the panel says why the cage crossed
    eight = [[50, 30], [120, 30], [190, 30], [190, 60], [190, 90], [120, 90], [50, 90], [50, 60]]

    def narrowed(s):
        s.set_cage("bar", {"points": eight, "coordinates": "green"}, vertices=[0, None, 1, None, None, None, 3, None])  # cage2 dropped
        for name, at in (("a", (75, 52)), ("b", (165, 52)), ("c", (75, 68)), ("e", (165, 68))):
            s.add_pin(name, "bar", at)
            s.set_target(name, (120 + (at[0] - 120) * 0.6, at[1]))
    d.app.edit(narrowed)
    d.app.selected_layer = "bar"  # the Deform panel shows the selected layer's cage
    d.settle()
    d.frame(2)
    C = deformtools.shown_cage(d.app, 0)
    assert len(d.scene().to_dict()["pins"]) == 4
    assert deformtools.cage_crossed(d.app, 0) and check_cage(C) is not None
    assert "cage:green bends" in RECTS
    d.app.edit(lambda s: s.set_cage("bar", {"points": eight, "coordinates": "mvc"}))
    d.settle()
    RECTS.pop("cage:green bends")
    d.frame(2)
    assert not deformtools.cage_crossed(d.app, 0) and "cage:green bends" not in RECTS
