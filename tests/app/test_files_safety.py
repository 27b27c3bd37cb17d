"""Issue 20 (11) in the app: after an autosave, Ctrl+S writes painted pixels into
``SCENE.files/`` (never into ``NAME.autosave.files/``); File > Open with unsaved changes asks
once and keeps the open scene when the new file fails to open; the autosave never deletes or
replaces a file that is not its own."""
from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest
from pyglet.window import key

import puppet
from puppet.app.model import autosave
from puppet.app.tools import mask as masktools
from puppet.output import OutputError
from tests.app.harness import Driver, widget
from tests.cli.outputs_helpers import bounded  # noqa: F401  (the fixture)
from tests.app.test_files import move_left_pin
from tests.conftest import bar_image, bar_scene, write_rgba

pytestmark = [pytest.mark.gl, pytest.mark.usefixtures("bounded")]


def paint_red(d, x0=30, x1=60):
    def rect(shape):
        m = np.zeros(shape, bool)
        m[10:30, x0:x1] = True
        return m
    d.app.edit(lambda s: masktools.paint(s, "bar", rect, (250, 0, 0)))
    d.settle()


def painted_and_autosaved(make_scene):
    """The app on the bar scene with a red patch painted and autosaved at once: (driver, path)."""
    path = make_scene(bar_scene(), {"bar.png": bar_image()})
    d = Driver(path, autosave_interval=0.0)
    paint_red(d)
    d.frame(2)
    d.settle()
    return d, path


def test_save_after_an_autosave_writes_pixels_beside_the_scene(make_scene, tmp_path):
    d, path = painted_and_autosaved(make_scene)
    try:
        assert os.path.exists(tmp_path / "scene.autosave.json") and os.listdir(tmp_path / "scene.autosave.files")
        shown = d.scene().render()
        d.key(key.S, key.MOD_CTRL)
        d.settle()
        assert d.app.status.level != "error" and not d.app.snap.dirty
        doc = json.loads(open(path).read())
        files = [doc["layers"][0]["image"], doc["layers"][0]["mask"]["file"]]
        assert all(f.startswith("scene.files/") for f in files), files
        # the save removed the autosave and its pixels
        assert sorted(os.listdir(tmp_path)) == ["bar.png", "scene.files", "scene.json"]
    finally:
        d.close()
    moved = tmp_path / "moved"
    os.makedirs(moved)
    for name in ("bar.png", "scene.json", "scene.files"):
        shutil.move(str(tmp_path / name), str(moved / name))
    again = puppet.load_scene(str(moved / "scene.json"))
    np.testing.assert_array_equal(again.render(), shown)
    again.close()


def test_recovered_pixels_are_saved_beside_the_scene(make_scene, tmp_path):
    d, path = painted_and_autosaved(make_scene)
    try:
        shutil.copytree(tmp_path, tmp_path.parent / (tmp_path.name + "-crash"))  # what a crash leaves
    finally:
        d.close()
    crash = tmp_path.parent / (tmp_path.name + "-crash")
    path = str(crash / "scene.json")
    os.utime(crash / "scene.autosave.json", (os.path.getmtime(path) + 5,) * 2)
    d = Driver(path)
    try:
        d.click(*widget("Recover"))
        d.settle()
        d.key(key.S, key.MOD_CTRL)
        d.settle()
        doc = json.loads(open(path).read())
        assert doc["layers"][0]["image"].startswith("scene.files/"), doc["layers"][0]
        assert sorted(os.listdir(crash)) == ["bar.png", "scene.files", "scene.json"]
    finally:
        d.close()


def test_open_with_unsaved_changes_asks_once_and_keeps_the_scene_on_failure(make_scene, tmp_path):
    path = make_scene(bar_scene(), {"bar.png": bar_image()})
    (tmp_path / "broken.json").write_text('{"puppet": 1, "layers": [{"name": "x", "image": "none.png"}]}')
    d = Driver(path)
    try:
        move_left_pin(d)
        before = d.scene().to_dict()
        assert d.app.snap.dirty
        d.key(key.O, key.MOD_CTRL)
        d.key(key.A, key.MOD_CTRL)
        d.type(str(tmp_path / "broken.json"))
        d.key(key.ENTER)
        d.frame(2)
        assert d.app.dialog == "unsaved"
        d.click(*widget("Don't save"))
        d.settle()
        d.frame(3)
        d.settle()
        assert d.app.dialog is None  # asked once
        assert d.app.status.level == "error" and "none.png" in d.app.status.text
        assert d.app.snap.loaded and d.app.snap.file == path and d.scene().to_dict() == before
        d.key(key.S, key.MOD_CTRL)  # the first document is still there to save
        d.settle()
        assert json.loads(open(path).read())["pins"][0]["at"] == before["pins"][0]["at"] != [15, 20]
    finally:
        d.close()


def test_autosave_leaves_files_that_are_not_its_own(make_scene, tmp_path):
    scene = bar_scene()
    scene["layers"][0]["image"] = "scene.autosave.json"  # a picture with that name
    path = make_scene(scene, {})
    write_rgba(tmp_path / "pic.png", bar_image())
    os.rename(tmp_path / "pic.png", tmp_path / "scene.autosave.json")
    before = (tmp_path / "scene.autosave.json").read_bytes()
    autosave.remove(path)
    assert (tmp_path / "scene.autosave.json").read_bytes() == before
    s = puppet.load_scene(path)
    with pytest.raises(OutputError, match="not an autosave"):
        autosave.write(s)
    s.close()
    assert (tmp_path / "scene.autosave.json").read_bytes() == before
    # a link at the autosave's name is neither followed nor removed
    os.remove(tmp_path / "scene.autosave.json")
    (tmp_path / "elsewhere.json").write_text(json.dumps(bar_scene()))
    os.symlink("elsewhere.json", tmp_path / "scene.autosave.json")
    autosave.remove(path)
    assert os.path.islink(tmp_path / "scene.autosave.json")
    keep = (tmp_path / "scene.autosave.files")
    keep.mkdir()
    (keep / "notes.txt").write_text("mine")
    autosave.remove(path)
    assert (keep / "notes.txt").read_text() == "mine"


def pin_moved(make_scene, interval: float):
    """The app on the bar scene with its left pin moved (unsaved), autosaving every
    ``interval`` seconds: (driver, path)."""
    path = make_scene(bar_scene(), {"bar.png": bar_image()})
    d = Driver(path, autosave_interval=interval)
    move_left_pin(d)
    d.frame(2)
    d.settle()
    return d, path


@pytest.mark.parametrize("autosaved", [True, False])
def test_a_loop_ended_by_an_exception_keeps_the_unsaved_changes(make_scene, capsys, autosaved):
    """Ctrl+C in the terminal (or a bug) ends the window's loop with an exception: the
    window closes, and the unsaved changes stay in the autosave (written once more when
    the periodic one had not run yet), which the next open offers to recover. Before, the
    close removed the autosave."""
    d, path = pin_moved(make_scene, 0.0 if autosaved else 1e9)
    auto = autosave.path_for(path)
    moved = d.scene().to_dict()["pins"][0]["at"]
    assert os.path.exists(auto) == autosaved

    def interrupted():
        raise KeyboardInterrupt

    d.w.step = interrupted
    with pytest.raises(KeyboardInterrupt):
        d.w.run()
    assert d.w.closed and autosave.is_autosave(auto)
    assert json.load(open(auto))["pins"][0]["at"] == moved
    assert f"unsaved changes kept in {auto}" in capsys.readouterr().err
    os.utime(auto, (os.path.getmtime(path) + 5,) * 2)
    d = Driver(path)
    try:
        assert d.app.dialog == "recover"
    finally:
        d.close()


def test_a_normal_quit_still_removes_the_autosave(make_scene):
    d, path = pin_moved(make_scene, 0.0)
    assert os.path.exists(autosave.path_for(path))
    d.app.quit_now = True  # as "Don't save" in the unsaved-changes dialog leaves it
    d.w.run()
    assert d.w.closed and not os.path.exists(autosave.path_for(path))
