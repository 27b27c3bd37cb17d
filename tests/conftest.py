"""Shared fixtures: small synthetic scenes written to a temporary folder."""
from __future__ import annotations

import functools
import json
import os
import signal
import threading

import numpy as np
import pytest
from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ASSETS = os.path.join(ROOT, "assets")
SCENES = os.path.join(ASSETS, "scenes")
#: the app's native file dialogs cannot be clicked by a test: the path field instead
#: (inherited by the apps the tests start under Xvfb; see puppet/app/ui/files.py)
os.environ["PUPPET_FILE_DIALOG"] = os.environ.get("PUPPET_TEST_FILE_DIALOG", "field")
#: no disk cache beside the scenes tests load (assets/ included); tests/scene/rig/test_disk.py turns it on
os.environ["PUPPET_CACHE"] = "off"
#: the commands tests stop with SIGINT must see it: a background job of a shell script (``.ci/run &``
#: in a script) starts with SIGINT ignored, which every child inherits across exec (Python then
#: never raises KeyboardInterrupt: a `puppet animate` stopped by SIGINT ran to its end, exit 0);
#: a handler, unlike SIG_IGN, is reset to the default in each child
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN and threading.current_thread() is threading.main_thread():
    signal.signal(signal.SIGINT, signal.default_int_handler)


# -- the gl and xvfb marks are kept true (``-m "not gl and not slow and not xvfb"`` is the fast subset)
# gl: a test that makes an OpenGL context in this process (``moderngl.create_context``,
# ``create_standalone_context`` or ``init_context``: puppet.render.context, a Compositor, the
# app's window) but is not marked ``gl`` fails, naming the mark. Checked while the test's
# set-up, call and teardown run, so it holds however the context comes (a fixture, a helper,
# the test's body). A ``puppet`` command run as a subprocess is out of its sight; to check
# those, PUPPET_TEST_HIDE_EGL=1 hides EGL from the subprocesses of tests not marked gl (so
# theirs fail as on a machine without GL):
#   PUPPET_TEST_HIDE_EGL=1 .venv/bin/python -m pytest -m "not gl and not xvfb"
# (only with the gl tests left out: a subprocess started then, a Dask worker say, would keep
# EGL hidden for later tests)
# xvfb: a test that uses the ``display`` fixture (a private Xvfb server, tests/app/test_xvfb.py)
# but is not marked ``xvfb`` stops the collection.
_running: list = []  # the test item whose set-up, call or teardown runs now
_GL_UNMARKED = pytest.StashKey[str]()
_HIDE_EGL = os.environ.get("PUPPET_TEST_HIDE_EGL") == "1"


def _watch_gl_contexts() -> None:
    try:
        import moderngl
    except ImportError:  # no GL at all: nothing to watch
        return

    def watched(make):
        @functools.wraps(make)
        def wrapper(*args, **kwargs):
            for item in _running:
                if item.get_closest_marker("gl") is None and _GL_UNMARKED not in item.stash:
                    item.stash[_GL_UNMARKED] = f"moderngl.{make.__name__}"
            return make(*args, **kwargs)

        wrapper.puppet_watched = True
        return wrapper

    for name in ("create_context", "init_context"):  # create_standalone_context calls create_context
        make = getattr(moderngl, name, None)
        if make is not None and not getattr(make, "puppet_watched", False):
            setattr(moderngl, name, watched(make))


_watch_gl_contexts()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _running.append(item)
    hide = _HIDE_EGL and item.get_closest_marker("gl") is None
    if hide:  # libglvnd finds no EGL driver (this process's EGL, if loaded, chose its driver already)
        vendors = os.environ.get("__EGL_VENDOR_LIBRARY_FILENAMES")
        os.environ["__EGL_VENDOR_LIBRARY_FILENAMES"] = "/nonexistent/egl-hidden-for-a-test-not-marked-gl.json"
    try:
        yield
    finally:
        _running.remove(item)
        if hide:
            os.environ.pop("__EGL_VENDOR_LIBRARY_FILENAMES")
            if vendors is not None:
                os.environ["__EGL_VENDOR_LIBRARY_FILENAMES"] = vendors


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    made = item.stash.get(_GL_UNMARKED, None)
    if made and report.passed and call.when in ("call", "teardown"):
        item.stash[_GL_UNMARKED] = ""  # reported once
        report.outcome = "failed"
        report.longrepr = (f"{item.nodeid} makes an OpenGL context ({made}) but is not marked gl: add "
                           "@pytest.mark.gl (or the module's pytestmark), so that -m \"not gl\" leaves it out")


def pytest_collection_modifyitems(config, items):
    unmarked = [item.nodeid for item in items
                if "display" in item.fixturenames and item.get_closest_marker("xvfb") is None]
    if unmarked:
        raise pytest.UsageError("these tests use the Xvfb display fixture but are not marked xvfb: "
                                + ", ".join(unmarked))


@pytest.fixture(autouse=True, scope="session")
def _config_home(tmp_path_factory):
    """The app's recent files go to a temporary config folder, never the user's."""
    os.environ["XDG_CONFIG_HOME"] = str(tmp_path_factory.mktemp("config"))


def write_rgba(path, rgba):
    Image.fromarray(np.asarray(rgba, np.uint8)).save(path)
    return path


def bar_image(w=120, h=40, box=(10, 10, 110, 30), colour=(200, 40, 40)):
    """An RGBA image, transparent but for one opaque rectangle (x0, y0, x1, y1)."""
    a = np.zeros((h, w, 4), np.uint8)
    x0, y0, x1, y1 = box
    a[y0:y1, x0:x1, :3] = colour
    a[y0:y1, x0:x1, 3] = 255
    return a


@pytest.fixture
def make_scene(tmp_path):
    """``make_scene(dict, images={name: rgba}) -> path`` writes images and the scene JSON."""

    def make(scene: dict, images: dict | None = None, name: str = "scene.json") -> str:
        for fname, rgba in (images or {}).items():
            write_rgba(tmp_path / fname, rgba)
        path = tmp_path / name
        path.write_text(json.dumps(scene))
        return str(path)

    return make


def bar_scene() -> dict:
    """A valid one-layer scene: a red bar with pins at both ends and a 'bend' pose."""
    return {
        "puppet": 1,
        "canvas": [120, 40],
        "background": [255, 255, 255, 255],
        "layers": [{"name": "bar", "image": "bar.png"}],
        "pins": [{"name": "left", "layer": "bar", "at": [15, 20]},
                 {"name": "right", "layer": "bar", "at": [105, 20]}],
        "poses": {"bend": {"right": [100, 5]}},
        "animation": {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "bend"}]},
    }


@pytest.fixture
def bar(make_scene):
    """Path of the valid bar scene (image included)."""
    return make_scene(bar_scene(), {"bar.png": bar_image()})
