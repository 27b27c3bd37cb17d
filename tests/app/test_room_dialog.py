"""File > Export dressing room (issue 34) in a headless window: the open scene as the
mannequin, garment scenes added by path (a wrong one refused in the dialog), one taken
out again, Export runs ``puppet dressroom`` in a child and the page is written."""
from __future__ import annotations

import os

import pytest
from pyglet.window import key

import puppet
from puppet.app.model import room_export
from puppet.app.ui.actions import ACTIONS
from tests.app.harness import Driver, widget

pytestmark = pytest.mark.gl

ROOM = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                    "assets", "scenes", "room")


@pytest.fixture
def room(tmp_path):
    for name in ("mannequin", "jeans", "shoes", "blue-tee"):
        puppet.load_scene(os.path.join(ROOM, f"{name}.json")).save(str(tmp_path / f"{name}.json"), copy=True)
    drv = Driver(str(tmp_path / "mannequin.json"), size=(1280, 900))
    yield drv, tmp_path
    drv.close()


def add(d, path) -> None:
    d.click(*widget("room:garment"))
    d.key(key.A, key.MOD_CTRL)  # what a refused path left there is replaced
    d.type(str(path))
    d.key(key.ENTER)
    d.frame(2)


def test_garments_added_and_the_room_written(room):
    d, tmp = room
    d.settle()
    next(a for a in ACTIONS if a.name == "dressroom").run(d.app, d.w)
    d.frame(3)
    assert d.app.dialog == "dressroom"
    f = room_export.form(d.app)
    assert f.output == str(tmp / "mannequin-room.html")
    add(d, tmp / "nothing.json")
    assert f.state == "failed" and "not a scene file" in f.message and f.garments == []
    add(d, tmp / "jeans.json")
    for name in ("blue-tee", "shoes"):  # Enter keeps the field's focus: the next path is typed without a click
        d.key(key.A, key.MOD_CTRL)
        d.type(str(tmp / f"{name}.json"))
        d.key(key.ENTER)
        d.frame(2)
    assert [os.path.basename(p) for p in f.garments] == ["jeans.json", "blue-tee.json", "shoes.json"]
    d.click(*widget("x##room-1"))  # blue-tee taken out again
    d.frame(2)
    assert [os.path.basename(p) for p in f.garments] == ["jeans.json", "shoes.json"]
    d.click(*widget("Export##room"))
    d.frame(2)
    assert f.wait(180) and f.state == "done", f.message
    page = (tmp / "mannequin-room.html").read_text()
    assert "<canvas" in page and "jeans" in page and "blue tee" not in page
    assert "2 garments written" in f.message
