""""Rig automatically" in the app's Link and Pins steps (issue 32): the anatomy rig is
proposed and drawn before it is accepted, Accept adds it in one undo step, Discard and a
changed scene drop it; a user's own pins and links are kept."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.scene.make.anatomy import rig_scene
from puppet.scene.make.art import import_art
from tests.app.harness import Driver, widget
from tests.artfiles import ROBOT_CANVAS, robot, write_psd_layers

pytestmark = pytest.mark.gl


def click(d, label):
    d.click(*widget(label))
    d.settle()


def magenta(d) -> int:
    px = d.pixels()[..., :3].astype(int)
    return int(((px[..., 0] > 200) & (px[..., 1] < 150) & (px[..., 2] > 190)).sum())


def test_propose_draw_accept_in_one_step_then_undo(tmp_path):
    art = tmp_path / "robot.psd"
    write_psd_layers(str(art), robot(), ROBOT_CANVAS)
    import_art(str(art), str(tmp_path / "s.json"))  # no rig
    d = Driver(str(tmp_path / "s.json"), size=(960, 640))
    try:
        app = d.app
        click(d, "step:link")
        before = magenta(d)
        click(d, "Rig automatically")
        assert "proposed: 12 pins, 14 hinges" in app.status.text, app.status.text
        assert not d.scene().data.pins and not d.scene().data.links  # not the scene's yet
        d.frame(2)
        assert magenta(d) > before + 200  # drawn over the canvas
        undo_depth = len(d.scene().history.undo_stack)
        want = rig_scene(d.scene())
        click(d, "Accept")
        doc = d.scene().to_dict()
        assert doc["pins"] == want.pins and doc["links"] == want.links
        assert doc["deformer"]["accelerate"] == "anderson"
        assert len(d.scene().history.undo_stack) == undo_depth + 1
        assert d.scene().history.undo_stack[-1].label == "rig automatically"
        d.frame(2)
        assert magenta(d) <= before + 20  # the proposal is gone: the scene's own markers show
        # in the Pins step, with the rig there, nothing more is proposed
        click(d, "step:pins")
        click(d, "Rig automatically")
        assert "nothing to add" in app.status.text
        app.undo()
        d.settle()
        assert not d.scene().data.pins and not d.scene().data.links
        # Discard drops a proposal; so does a change of the scene under it
        click(d, "Rig automatically")
        click(d, "Discard")
        assert app.script.rig_proposal is None
        click(d, "Rig automatically")
        app.edit(lambda s: s.add_pin("mine", "torso", (200, 250)))
        d.settle()
        click(d, "step:link")
        assert np.all(magenta(d) <= before + 20)
    finally:
        d.close()
