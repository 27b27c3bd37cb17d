"""The start page (no file given: Open..., recent files, the bundled examples) and the
recent files kept by the window (issue 23)."""
from __future__ import annotations

import json
import os

import pytest

from puppet.app import recent
from tests.app.harness import Driver, widget
from tests.conftest import SCENES, bar_image, bar_scene

pytestmark = pytest.mark.gl


def test_start_page_opens_an_example_and_remembers_it(tmp_path, make_scene):
    store = str(tmp_path / "config" / "recent.json")
    scene = make_scene(bar_scene(), {"bar.png": bar_image()})
    recent.add(store, scene)
    d = Driver(None, recent_file=store)
    try:
        assert not d.app.snap.loaded
        assert "start:recent:scene.json" in _rects() and "start:examples:trex-layers.json" in _rects()
        d.click(*widget("start:open"))
        assert d.app.dialog == "open"
        d.app.dialog = None
        d.frame(2)
        d.click(*widget("start:examples:strips.json"))
        d.settle()
        assert d.app.snap.file == os.path.join(SCENES, "strips.json") and d.app.mode == "pose"
        d.frame(2)
        assert recent.load(store) == [os.path.join(SCENES, "strips.json"), scene]
    finally:
        d.close()


def test_recent_list_is_bounded_and_skips_missing_files(tmp_path):
    store = str(tmp_path / "recent.json")
    files = []
    for k in range(recent.LIMIT + 3):
        p = tmp_path / f"s{k}.json"
        p.write_text("{}")
        files.append(str(p))
        recent.add(store, str(p))
    assert recent.load(store) == files[::-1][:recent.LIMIT]
    os.remove(files[-1])
    assert recent.load(store)[0] == files[-2]
    recent.add(store, files[-3])  # again: moved to the front, not repeated
    got = recent.load(store)
    assert got[0] == files[-3] and got.count(files[-3]) == 1
    (tmp_path / "bad.json").write_text("not json")
    assert recent.load(str(tmp_path / "bad.json")) == [] and recent.load(None) == []
    assert json.load(open(store))[0] == files[-3]


def _rects():
    from puppet.app.widgets import RECTS

    return RECTS


def test_native_dialogs_only_where_they_can_show(monkeypatch):
    from puppet.app import native_dialogs

    assert not native_dialogs.available(headless=True)  # headless windows use the path field
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(native_dialogs.shutil, "which", lambda p: "/usr/bin/" + p if p == "zenity" else None)
    assert native_dialogs.available(headless=False)
    monkeypatch.setenv("PUPPET_NATIVE_DIALOGS", "0")
    assert not native_dialogs.available(headless=False)
    monkeypatch.delenv("PUPPET_NATIVE_DIALOGS")
    monkeypatch.setattr(native_dialogs.shutil, "which", lambda p: None)
    assert not native_dialogs.available(headless=False)  # no dialog program: the path field


def test_a_chosen_reference_picture_is_set(make_scene, tmp_path, monkeypatch):
    """The reference picture's *...* button: what the native dialog answers becomes the
    reference (the dialog itself stood in for: a headless window has none)."""
    from puppet.app import native_dialogs
    from tests.conftest import write_rgba

    picture = str(write_rgba(tmp_path / "ref.png", bar_image()))
    asked = []

    def ask(kind, start, on_done):
        asked.append(kind)
        on_done(picture)
        return True
    monkeypatch.setattr(native_dialogs, "ask", ask)
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(960, 900))
    try:
        d.click(*widget("header:Reference picture"))
        d.frame(2)
        d.click(*widget("...##underlay"))
        d.settle()
        assert asked == ["picture"] and d.app.snap.underlay["image"] == picture
    finally:
        d.close()
