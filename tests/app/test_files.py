"""Files and editing safety: save, save as, the title's unsaved mark, quitting with
unsaved changes, File > Open from an empty window, bad scenes on the status line, the
autosave and its recovery."""
from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest
from pyglet.window import key

import puppet
from tests.app.harness import Driver, widget
from tests.conftest import bar_image, bar_scene

pytestmark = pytest.mark.gl


def move_left_pin(d, dx=10):
    d.key(key._1)
    a = d.pin_screen("left")
    d.drag_path([a, (a[0] + 3, a[1]), (a[0] + dx * d.app.view.scale, a[1])])
    d.settle()


def test_save_writes_the_scene_and_clears_the_mark(bar_app):
    d = bar_app
    path = d.app.snap.file
    move_left_pin(d)
    assert d.app.title == "puppet — scene.json *"
    d.key(key.S, key.MOD_CTRL)
    d.settle()
    assert d.app.title == "puppet — scene.json"
    saved = puppet.load_scene(path)
    assert saved.to_dict() == d.scene().to_dict()  # valid v1, same content
    np.testing.assert_array_equal(saved.render(pose="bend"), d.scene().render(pose="bend"))
    saved.close()
    assert not os.path.exists(path + ".tmp") and sorted(os.listdir(os.path.dirname(path))) == ["bar.png", "scene.json"]


def test_save_as_then_title_follows(bar_app, tmp_path):
    d = bar_app
    move_left_pin(d)
    d.key(key.S, key.MOD_CTRL | key.MOD_SHIFT)
    assert d.app.dialog == "save_as"
    d.key(key.A, key.MOD_CTRL)  # select the proposed path in the field, then type over it
    d.type(str(tmp_path / "sub" / "copy"))
    d.key(key.ENTER)
    d.settle()
    # the folder does not exist: the status line says so, the window lives
    assert d.app.status.level == "error" and d.app.snap.file.endswith("scene.json")
    os.makedirs(tmp_path / "sub")
    d.key(key.S, key.MOD_CTRL | key.MOD_SHIFT)
    d.key(key.A, key.MOD_CTRL)
    d.type(str(tmp_path / "sub" / "copy"))
    d.key(key.ENTER)
    d.settle()
    assert d.app.snap.file == str(tmp_path / "sub" / "copy.json") and d.app.title == "puppet — copy.json"
    doc = json.loads((tmp_path / "sub" / "copy.json").read_text())
    assert doc["layers"][0]["image"] == "../bar.png"  # paths follow the new folder


def test_quit_with_unsaved_changes_asks(bar_app):
    d = bar_app
    d.key(key.Q, key.MOD_CTRL)
    assert d.app.quit_now  # nothing to lose: quits at once
    d.app.quit_now = False
    move_left_pin(d)
    d.w.win.dispatch_event("on_close")  # the window's close button
    d.frame(2)
    assert d.app.dialog == "unsaved" and not d.app.quit_now and not d.w.win.has_exit
    d.click(*widget("Cancel"))
    d.settle()
    assert d.app.dialog is None and not d.app.quit_now
    d.key(key.Q, key.MOD_CTRL)
    d.frame()
    d.click(*widget("Save"))
    d.settle()
    assert d.app.quit_now and not d.app.snap.dirty


def test_dont_save_quits_without_writing(bar_app):
    d = bar_app
    before = open(d.app.snap.file).read()
    move_left_pin(d)
    d.key(key.Q, key.MOD_CTRL)
    d.frame()
    d.click(*widget("Don't save"))
    d.settle()
    assert d.app.quit_now and open(d.app.snap.file).read() == before


def test_dont_save_then_opens_the_other_scene(bar_app, make_scene):
    """File > Open over unsaved changes, "Don't save": the other scene opens (once)."""
    d = bar_app
    first = d.app.snap.file
    before = open(first).read()
    other = make_scene(bar_scene(), {"bar.png": bar_image()}, name="other.json")
    move_left_pin(d)
    d.key(key.O, key.MOD_CTRL)
    d.key(key.A, key.MOD_CTRL)
    d.type(other)
    d.key(key.ENTER)
    d.frame()
    assert d.app.dialog == "unsaved"
    d.click(*widget("Don't save"))
    d.settle()
    assert d.app.dialog is None and d.app.snap.file == other and not d.app.snap.dirty
    assert open(first).read() == before  # nothing written

def test_empty_window_then_file_open(make_scene):
    path = make_scene(bar_scene(), {"bar.png": bar_image()})
    d = Driver()
    try:
        assert d.app.title == "puppet" and not d.app.snap.loaded and d.ready
        d.key(key.O, key.MOD_CTRL)
        assert d.app.dialog == "open"
        d.key(key.A, key.MOD_CTRL)
        d.type(path)
        d.key(key.ENTER)
        d.settle()
        assert d.app.snap.loaded and d.app.title == "puppet — scene.json"
        assert d.app.view.scale > 1  # fitted
    finally:
        d.close()


def test_a_bad_scene_shows_on_the_status_line(make_scene):
    doc = bar_scene()
    path = make_scene(doc, {})  # bar.png missing
    d = Driver(path)
    try:
        assert not d.app.snap.loaded
        assert d.app.status.level == "error" and "bar.png" in d.app.status.text
        d.frame(3)  # still drawing
        with open(os.path.join(os.path.dirname(path), "bar.png"), "wb") as f:
            f.write(b"not a png")
        d.w.open_scene(path)
        d.settle()
        assert not d.app.snap.loaded and d.app.status.level == "error"
    finally:
        d.close()


def test_autosave_and_recovery(make_scene, tmp_path):
    path = make_scene(bar_scene(), {"bar.png": bar_image()})
    auto = str(tmp_path / "scene.autosave.json")
    d = Driver(path, autosave_interval=0.0)
    try:
        move_left_pin(d)
        d.frame(2)
        d.settle()
        assert os.path.exists(auto)
        np.testing.assert_allclose(json.load(open(auto))["pins"][0]["at"], d.scene().to_dict()["pins"][0]["at"])
        shutil.copy(auto, str(tmp_path / "kept.json"))  # what a crash would leave behind
    finally:
        d.close()
    assert not os.path.exists(auto)  # a normal exit removes it
    shutil.copy(str(tmp_path / "kept.json"), auto)
    os.utime(auto, (os.path.getmtime(path) + 5,) * 2)
    d = Driver(path)
    try:
        assert d.app.dialog == "recover" and not d.app.snap.loaded
        d.click(*widget("Recover"))
        d.settle()
        assert d.app.snap.loaded and d.app.snap.dirty and d.app.snap.file == path
        assert d.scene().to_dict()["pins"][0]["at"] != [15.0, 20.0]
    finally:
        d.close()
    shutil.copy(str(tmp_path / "kept.json"), auto)
    os.utime(auto, (os.path.getmtime(path) + 5,) * 2)
    d = Driver(path)
    try:
        d.click(*widget("Discard"))
        d.settle()
        assert not d.app.snap.dirty and not os.path.exists(auto)
        assert d.scene().to_dict()["pins"][0]["at"] == [15.0, 20.0]
    finally:
        d.close()


def test_help_overlay(bar_app):
    d = bar_app
    before = d.pixels()
    d.type("?")  # the character, whatever the keyboard layout makes it with
    assert d.app.show_help
    d.frame(2)  # an auto-sized window shows from its second frame
    shown = d.pixels()
    assert (np.abs(shown.astype(int) - before).sum(axis=2) > 30).sum() > 20000  # a big panel
    d.key(key.ESCAPE)
    assert not d.app.show_help
