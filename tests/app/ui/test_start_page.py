"""The start page (no file given: Open..., recent files, the bundled examples), where
native dialogs can show, and a reference picture chosen in one (issue 23). The recent
files themselves are tested in test_open_files.py."""
from __future__ import annotations

import os

import pytest

from puppet.app.model import recent
from puppet.app.ui import files
from puppet.app.ui.widgets import RECTS
from tests.app.harness import Driver, widget
from tests.conftest import SCENES, bar_image, bar_scene

pytestmark = pytest.mark.gl


@pytest.fixture
def config(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


def test_start_page_opens_an_example_and_remembers_it(config, make_scene):
    scene = make_scene(bar_scene(), {"bar.png": bar_image()})
    recent.add(scene)
    RECTS.clear()
    d = Driver(None)
    try:
        assert not d.app.snap.loaded
        assert "recent:scene.json" in RECTS and "example:trex-layers.json" in RECTS
        d.click(*widget("Open..."))
        assert d.app.dialog == "open"  # no dialog program (PUPPET_FILE_DIALOG=field): the path field
        d.app.dialog = None
        d.frame(2)
        d.click(*widget("example:strips.json"))
        d.settle()
        assert d.app.snap.file == os.path.join(SCENES, "strips.json") and d.app.mode == "pose"
        d.frame(2)
        assert recent.load() == [os.path.join(SCENES, "strips.json"), scene]
    finally:
        d.close()


def test_native_dialogs_only_where_they_can_show(monkeypatch):
    import pyglet

    monkeypatch.delenv(files.ENV, raising=False)
    monkeypatch.setitem(pyglet.options, "headless", True)
    assert not files.native_available()  # headless windows use the path field
    monkeypatch.setitem(pyglet.options, "headless", False)
    monkeypatch.setattr(files.sys, "platform", "linux")
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(files.shutil, "which", lambda p: "/usr/bin/" + p if p == "zenity" else None)
    assert files.native_available()
    monkeypatch.setenv(files.ENV, "field")
    assert not files.native_available()
    monkeypatch.setenv(files.ENV, "native")
    monkeypatch.setattr(files.shutil, "which", lambda p: None)
    assert files.native_available()  # forced
    monkeypatch.delenv(files.ENV)
    assert not files.native_available()  # no dialog program: the path field
    monkeypatch.delenv("DISPLAY")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(files.shutil, "which", lambda p: "/usr/bin/" + p)
    assert not files.native_available()  # no display to show one on


class _Answered:
    """A finished dialog as portable-file-dialogs hands it back (``ready``, ``result``)."""

    def __init__(self, path):
        self.path = path

    def ready(self, timeout):
        return True

    def result(self):
        return [self.path]


def test_a_chosen_reference_picture_is_set(make_scene, tmp_path, monkeypatch):
    """The reference picture's *Browse...* button: what the native dialog answers becomes
    the reference (the dialog itself stood in for: a headless window has none; the real
    one runs in test_xvfb_files.py)."""
    from tests.conftest import write_rgba

    picture = str(write_rgba(tmp_path / "ref.png", bar_image()))
    asked = []

    def start(kind, default):
        asked.append(kind)
        return _Answered(picture)
    monkeypatch.setattr(files, "_start", start)
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(960, 900))
    try:
        d.w.files.native = True
        d.click(*widget("header:Reference picture"))
        d.frame(2)
        d.click(*widget("Browse...##underlay"))
        d.settle()
        assert asked == ["picture"] and d.app.snap.underlay["image"] == picture
    finally:
        d.close()
