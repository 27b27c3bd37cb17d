"""Hinges and patches in the Link step, as issue 32 found them: the hinge tool links the
Link step's layer A and B (not the layer selected in the Layers panel), the step's list
shows hinge and patch links and removes each part (one undo step), and a mode switch gives
the canvas back to the mode's own tool (a click in Pose mode never adds a hinge)."""
from __future__ import annotations

import numpy as np
import pytest
from pyglet.window import key

from tests.app.harness import Driver, widget
from tests.conftest import bar_image as img

pytestmark = pytest.mark.gl

#: the three layers all cover canvas (100, 50): back (whole canvas), mid, front
SPOT = (100.0, 50.0)


@pytest.fixture
def three(make_scene):
    scene = {"puppet": 1, "canvas": [200, 100], "background": [255, 255, 255, 255],
             "layers": [{"name": "back", "image": "back.png"},
                        {"name": "mid", "image": "mid.png", "offset": [40, 20]},
                        {"name": "front", "image": "front.png", "offset": [80, 30]}],
             "pins": [{"name": "p", "layer": "front", "at": [150, 50]}]}
    path = make_scene(scene, {"back.png": img(200, 100, (10, 10, 190, 90), (200, 40, 40)),
                              "mid.png": img(120, 60, (0, 0, 120, 60), (40, 160, 40)),
                              "front.png": img(100, 40, (0, 0, 100, 40), (40, 40, 200))})
    d = Driver(path, size=(1100, 900))
    yield d
    d.close()


def link_step(d, a, b):
    """The Link step with layer A = ``a`` and layer B = ``b`` (the boxes' values)."""
    d.click(*widget("step:link"))
    d.settle()
    d.app.script.link_a, d.app.script.link_b = a, b
    d.frame(2)
    assert d.app.script.link_pair(d.app) == (a, b)


def steps(d) -> int:
    return len(d.scene().history.undo_stack)


def test_the_link_steps_hinge_links_its_layers_a_and_b_not_the_selected_layer(three):
    d = three
    d.click(*widget("layer:front"))  # the layer selected in the Layers panel
    d.settle()
    assert d.app.selected_layer == "front"
    link_step(d, "back", "mid")
    d.click(*widget("link-step:hinge"))
    n = steps(d)
    d.click(*d.screen_of(SPOT))
    d.settle()
    assert steps(d) == n + 1, d.app.status.text
    (link,) = d.scene().data.links
    assert set(link.layers) == {"back", "mid"} and np.allclose(link.points, [SPOT], atol=1.0)
    # a click where A and B do not both lie: refused, naming them
    d.click(*d.screen_of((20.0, 50.0)))  # back only
    d.settle()
    assert steps(d) == n + 1 and "back and mid" in d.app.status.text


def test_hinge_and_patch_links_are_listed_in_the_link_step_and_removed_one_part_at_a_time(three):
    d = three
    d.app.edit(lambda s: s.add_link_point("back", "mid", SPOT))
    d.app.edit(lambda s: s.add_link_point("back", "mid", (60.0, 40.0)))
    d.app.edit(lambda s: s.add_link_polygon("mid", "front", [[90, 35], [110, 35], [100, 55]]))
    d.settle()
    link_step(d, "back", "mid")
    n = steps(d)
    d.click(*widget("remove-link:back-mid:points:0"))
    d.settle()
    links = {frozenset(k.layers): k for k in d.scene().data.links}
    assert steps(d) == n + 1 and np.allclose(links[frozenset(("back", "mid"))].points, [[60.0, 40.0]])
    d.frame(2)
    d.click(*widget("remove-link:back-mid:points:0"))  # its last part: the link goes
    d.settle()
    d.frame(2)
    d.click(*widget("remove-link:mid-front:polygons:0"))
    d.settle()
    assert not d.scene().data.links and steps(d) == n + 3
    d.key(key.Z, key.MOD_CTRL)
    d.settle()
    assert [len(k.polygons) for k in d.scene().data.links] == [1]


def test_a_mode_switch_gives_the_canvas_back_to_the_modes_tool(three):
    d = three
    d.key(key._1)  # Pin mode, where a rig is edited
    d.click(*widget("header:Deform"))
    d.settle()
    assert d.app.mode == "pin"
    d.click(*widget("deform-tool:hinge"))
    d.frame(2)
    d.key(key._2)  # Pose mode
    d.settle()
    assert d.app.mode == "pose"
    n = steps(d)
    d.click(*d.screen_of(SPOT))
    d.settle()
    assert not d.scene().data.links and steps(d) == n  # no hinge
    d.key(key._1)  # back in Pin mode the hinge tool is not chosen either: a click adds a pin
    d.settle()
    d.click(*d.screen_of(SPOT))
    d.settle()
    assert not d.scene().data.links and len(d.scene().data.pins) == 2
