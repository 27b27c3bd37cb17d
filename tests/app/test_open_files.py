"""Files in the app (issues 23 and 24): recent files, the start page, the path field when
there is no native dialog, a file dropped on the window, layered art opened in the app
and Reload art as one undo step.

The native dialog itself runs under Xvfb in test_xvfb_files.py; here
``PUPPET_FILE_DIALOG=field`` (tests/conftest.py) gives the path field."""
from __future__ import annotations

import hashlib
import json
import os

import numpy as np
import pytest

from puppet.app.model import recent
from puppet.app.ui import actions, start_page as startpage
from puppet.app.ui.widgets import RECTS
from tests import artfiles
from tests.app.harness import Driver, widget
from tests.conftest import SCENES


@pytest.fixture
def config(tmp_path, monkeypatch):
    folder = tmp_path / "config"
    monkeypatch.setenv("XDG_CONFIG_HOME", str(folder))
    return folder / "puppet"


def test_recent_files_newest_first_capped_written_atomically(tmp_path, config):
    assert recent.load() == []
    files = []
    for i in range(recent.KEEP + 2):
        f = tmp_path / f"s{i}.json"
        f.write_text("{}")
        files.append(str(f))
        recent.add(files[-1])
    items = recent.load()
    assert items == files[::-1][:recent.KEEP]  # newest first, at most KEEP
    assert recent.add(files[5])[0] == files[5] and recent.load().count(files[5]) == 1
    os.remove(files[-1])
    assert files[-1] not in recent.existing() and files[-1] in recent.load()
    assert os.listdir(config) == ["recent.json"]  # no temporary file left beside it
    (config / "recent.json").write_text("{not json")
    assert recent.load() == []  # an unreadable list reads as empty...
    assert recent.add(files[0]) == [files[0]] and recent.load() == [files[0]]  # ...and is replaced


def test_recent_files_never_an_error_when_the_config_folder_cannot_be_written(tmp_path, monkeypatch):
    (tmp_path / "cfg").write_text("a file where the folder would go")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "cfg"))
    assert recent.add(str(tmp_path / "x.json")) == [str(tmp_path / "x.json")]
    assert recent.load() == []


@pytest.mark.gl
def test_start_page_opens_an_example_then_lists_it_as_recent(config):
    RECTS.clear()
    d = Driver(None)
    try:
        assert startpage.shown(d.app) and "example:strips.json" in RECTS and "recent" not in str(RECTS)
        d.click(*widget("example:strips.json"))
        d.settle()
        assert d.app.snap.file == os.path.join(SCENES, "strips.json") and not startpage.shown(d.app)
        d.frame(2)
        assert recent.load() == [os.path.join(SCENES, "strips.json")]
    finally:
        d.close()
    RECTS.clear()
    d = Driver(None)
    try:
        assert "recent:strips.json" in RECTS  # the next start lists it
        d.click(*widget("recent:strips.json"))
        d.settle()
        assert d.app.snap.file == os.path.join(SCENES, "strips.json")
    finally:
        d.close()


@pytest.mark.gl
def test_without_a_dialog_program_open_is_the_path_field_and_takes_art(tmp_path, config):
    from pyglet.window import key

    art = tmp_path / "gbot.ora"
    artfiles.write_ora(str(art))
    d = Driver(None)
    try:
        assert not d.w.files.native
        d.key(key.O, key.MOD_CTRL)
        assert d.app.dialog == "open" and d.w.files.pending is None
        d.key(key.A, key.MOD_CTRL)
        d.type(str(art))
        d.key(key.ENTER)
        d.settle()
        assert d.app.snap.file == str(tmp_path / "gbot.json") and d.w.files.art == str(art)
        assert [r.name for r in d.scene().layers("rest")] == ["sketch"] + artfiles.NAMES
    finally:
        d.close()


def sha(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


def layer_rgba(scene, name):
    from PIL import Image

    path = next(L["image"] for L in scene.to_dict()["layers"] if L["name"] == name)
    with Image.open(path) as im:
        return np.asarray(im.convert("RGBA"))


@pytest.fixture
def art_app(tmp_path, config):
    """The app with a seven-part PSD dropped on its start page."""
    art = tmp_path / "gbot.psd"
    artfiles.write_psd(str(art))
    d = Driver(None)
    d.w.win.dispatch_event("on_file_drop", 100, 100, [str(art)])
    d.settle()
    yield d, art
    d.close()


@pytest.mark.gl
def test_dropped_art_opens_as_the_scene_beside_it(art_app, tmp_path):
    d, art = art_app
    scene = tmp_path / "gbot.json"
    assert d.app.snap.file == str(scene) and [L["name"] for L in json.loads(scene.read_text())["layers"]] == \
        ["sketch"] + artfiles.NAMES  # the sketch kept hidden
    assert d.app.status.text.startswith(str(scene)) and "8 layer(s)" in d.app.status.text
    assert d.w.files.art == str(art) and not d.w.files.art_changed
    assert actions.BY_NAME["reload_art"].enabled(d.app)
    assert recent.load() == [str(scene)]


@pytest.mark.gl
@pytest.mark.slow
def test_reload_changed_art_is_one_undo_step_keeping_the_rig(art_app, tmp_path):
    d, art = art_app
    scene_file = tmp_path / "gbot.json"
    on_disk = scene_file.read_text()
    pins = d.scene().to_dict()["pins"]
    old_head = layer_rgba(d.scene(), "head").copy()
    artfiles.write_psd(str(art), recolour="head")
    os.utime(art, ns=(os.stat(art).st_atime_ns, os.stat(art).st_mtime_ns + 10**9))  # a later date, surely
    art_sha = sha(art)
    d.w.files._looked = 0.0
    d.frame()
    assert d.w.files.art_changed and "gbot.psd changed on disk" in d.app.status.text
    actions.BY_NAME["reload_art"].run(d.app, d.w)
    d.settle()
    assert d.app.status.text.startswith("reloaded the art: 8 replaced, 0 added, 0 removed; 1 hidden"), \
        d.app.status.text
    s = d.scene()
    new_head = layer_rgba(s, "head")
    opaque = old_head[..., 3] == 255
    assert np.abs(new_head[..., :3][opaque].astype(int) + old_head[..., :3][opaque] - 255).max() <= 1  # inverted
    assert s.to_dict()["pins"] == pins and d.app.snap.undo_label == "reload art"
    assert scene_file.read_text() == on_disk and sha(art) == art_sha  # nothing written until a save
    assert not d.w.files.art_changed
    d.app.undo()
    d.settle()
    assert np.array_equal(layer_rgba(d.scene(), "head"), old_head)  # the old pixels are back
    d.app.redo()
    d.settle()
    d.app.save()
    d.settle()
    from puppet.app.model.opening import from_art

    res = from_art(str(art))  # `puppet app gbot.psd` again: the saved scene still counts as made from it
    assert res.scene == str(scene_file) and res.replaced == ["sketch"] + artfiles.NAMES


@pytest.mark.gl
def test_art_newer_than_its_scene_is_offered_at_once(tmp_path, config):
    art = tmp_path / "gbot.psd"
    artfiles.write_psd(str(art))
    from puppet.app.model.opening import from_art

    scene = from_art(str(art)).scene
    st = os.stat(scene)
    os.utime(art, ns=(st.st_atime_ns, st.st_mtime_ns + 5 * 10**9))
    d = Driver(scene)
    try:
        d.frame()
        assert d.w.files.art_changed and "changed on disk" in d.app.status.text
    finally:
        d.close()


@pytest.mark.gl
def test_a_scene_without_art_has_no_reload(config):
    d = Driver(os.path.join(SCENES, "strips.json"))
    try:
        assert d.w.files.art is None and not actions.BY_NAME["reload_art"].enabled(d.app)
    finally:
        d.close()


@pytest.mark.gl
def test_start_page_lists_recent_newest_first(config):
    """(``PUPPET_UPDATE_DOCS=1``: docs/app/start-page.png; the folders shown depend on the checkout.)"""
    for name in ("horse.json", "dress.json", "trex-layers.json"):
        recent.add(os.path.join(SCENES, name))
    RECTS.clear()
    d = Driver(None, size=(1100, 760))
    try:
        ys = [RECTS[f"recent:{n}"][1] for n in ("trex-layers.json", "dress.json", "horse.json")]
        assert ys == sorted(ys) and RECTS["recent:horse.json"][1] < RECTS["example:character.json"][1]
        if os.environ.get("PUPPET_UPDATE_DOCS"):
            d.shot("start-page")
    finally:
        d.close()


@pytest.mark.gl
def test_reload_reports_a_layer_gone_with_its_pins_and_undo_brings_them_back(art_app):
    from PIL import Image
    from psd_tools import PSDImage

    d, art = art_app
    before = d.scene().to_dict()
    psd = PSDImage.new("RGBA", artfiles.CANVAS, color=(0, 0, 0, 0))
    for name, group, rgba, (x, y) in artfiles.parts():
        if group is None and name != "arm_front":  # the arm and the legs' group are gone
            psd.create_pixel_layer(Image.fromarray(rgba), name=name, top=y, left=x)
    psd.save(str(art))
    actions.BY_NAME["reload_art"].run(d.app, d.w)
    d.settle()
    text = d.app.status.text
    assert text.startswith("reloaded the art: 4 replaced, 0 added, 4 removed"), text
    assert "arm_front" in text and "pin(s) removed with their layers" in text
    after = d.scene().to_dict()
    assert [L["name"] for L in after["layers"]] == ["arm_back", "body", "neck", "head"]
    assert not any(p["layer"] in ("arm_front", "legs/left", "legs/right") for p in after["pins"])
    d.app.undo()
    d.settle()
    assert d.scene().to_dict()["pins"] == before["pins"] and len(d.scene().to_dict()["layers"]) == 8


@pytest.mark.gl
def test_dropping_several_files_on_unsaved_changes_asks_first(bar_app, tmp_path):
    d = bar_app
    d.app.move_pins({"left": (20.0, 22.0)})
    d.settle()
    assert d.app.snap.dirty
    other = os.path.join(SCENES, "strips.json")
    d.w.win.dispatch_event("on_file_drop", 50, 50, [other, os.path.join(SCENES, "horse.json")])
    d.frame()
    assert d.app.dialog == "unsaved" and d.app.after_dialog == ("open", other)
    assert d.app.status.text.startswith("2 files dropped: opening the first, strips.json")


def test_app_art_is_checked_kept_through_save_as_and_may_be_gone(tmp_path):
    import puppet
    from puppet.errors import SceneError
    from puppet.scene.make.art import art_of
    from tests.conftest import bar_image, bar_scene, write_rgba

    write_rgba(tmp_path / "bar.png", bar_image())
    doc = dict(bar_scene(), app={"art": 7})
    (tmp_path / "s.json").write_text(json.dumps(doc))
    with pytest.raises(SceneError, match="app.art"):
        puppet.load_scene(str(tmp_path / "s.json"))
    doc["app"] = {"art": "art/gone.psd"}  # the art need not exist (moved away, another machine)
    (tmp_path / "s.json").write_text(json.dumps(doc))
    s = puppet.load_scene(str(tmp_path / "s.json"))
    (tmp_path / "sub").mkdir()
    s.save(str(tmp_path / "sub" / "copy.json"))
    saved = json.loads((tmp_path / "sub" / "copy.json").read_text())
    assert saved["app"] == {"art": "../art/gone.psd"}  # relative to the new place, same file
    assert art_of(saved, str(tmp_path / "sub" / "copy.json")) == str(tmp_path / "art" / "gone.psd")


@pytest.mark.gl
def test_opening_the_art_again_takes_its_changes_and_clears_the_hint(art_app, tmp_path):
    d, art = art_app
    mtime = os.stat(art).st_mtime_ns
    artfiles.write_psd(str(art), recolour="head")
    os.utime(art, ns=(mtime - 10 * 10**9, mtime - 10 * 10**9))  # changed, yet older than its scene
    d.w.files._looked = 0.0
    d.frame()
    assert d.w.files.art_changed
    d.w.win.dispatch_event("on_file_drop", 100, 100, [str(art)])  # the art again: the scene updated from it
    d.settle()
    d.frame(2)
    assert d.app.snap.file == str(tmp_path / "gbot.json") and "8 replaced" in d.app.status.text
    assert not d.w.files.art_changed


@pytest.mark.gl
def test_reload_of_a_broken_art_file_says_so_and_changes_nothing(art_app):
    d, art = art_app
    before = d.scene().to_dict()
    art.write_bytes(b"8BPS\x00\x01 cut short by a crashed save")
    actions.BY_NAME["reload_art"].run(d.app, d.w)
    d.settle()
    assert d.app.status.level == "error" and "gbot.psd" in d.app.status.text, d.app.status.text
    assert d.scene().to_dict() == before and d.app.snap.undo_label is None


class _OpenDialog:
    """A native file dialog the user has not answered yet (its window is elsewhere)."""

    def ready(self, timeout=0):
        return False


@pytest.mark.gl
def test_keys_wait_while_a_native_dialog_is_open(bar):
    """Typing into a native dialog that did not take the focus (no window manager) must
    not reach the app: "1" would switch to Pin mode, Space would play."""
    from pyglet.window import key

    d = Driver(bar)
    try:
        assert d.app.mode == "pose"
        d.w.files.pending = (_OpenDialog(), lambda path: None)
        d.key(key._1)
        d.key(key.SPACE)
        assert d.app.mode == "pose" and not d.app.timeline.playing
        d.w.files.pending = None
        d.key(key._1)
        assert d.app.mode == "pin"  # the same key acts once the dialog is answered
    finally:
        d.close()
