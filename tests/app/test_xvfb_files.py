"""The native file dialog in a real X window (Xvfb + zenity, driven by xdotool): File >
Open shows zenity's chooser while the app keeps drawing (the dialog is polled, never
waited for), the path typed there opens the scene, and it lands in the recent files.
``PUPPET_UPDATE_DOCS=1`` also writes docs/app/file-dialog.png."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import time

import pytest

from tests.app.harness import DOCS_SHOTS
from tests.app.test_xvfb import display, pytestmark, screenshot, wait_title, x  # noqa: F401
from tests.cli.test_layered_xvfb import close, open_app
from tests.conftest import ROOT, SCENES

pytestmark = pytestmark + [pytest.mark.skipif(shutil.which("zenity") is None,
                                              reason="the native file dialog needs zenity (apt-get install zenity)")]
TITLE = "Open a scene, picture or layered art"


def rects(path):
    try:
        return json.loads(open(path).read())
    except (OSError, ValueError):
        return {}


def wait_status(info_file, text: str, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end and rects(info_file).get("status") != text:
        time.sleep(0.2)
    assert rects(info_file).get("status") == text, rects(info_file).get("status")


def test_native_open_dialog_is_polled_and_opens_the_file(display, tmp_path):  # noqa: F811
    info_file = tmp_path / "rects.json"
    env = dict(os.environ, DISPLAY=display, PYTHONPATH=ROOT, PUPPET_FILE_DIALOG="native",
               PUPPET_APP_RECTS=str(info_file), XDG_CONFIG_HOME=str(tmp_path / "config"))
    env.pop("PYGLET_HEADLESS", None)
    app, ready = open_app(None, env, SCENES, "--size", "1100x800")  # the dialog starts in the cwd
    try:
        win = x(display, "xdotool", "search", "--name", "^puppet$").split()[0]
        x(display, "xdotool", "windowfocus", "--sync", win)
        x(display, "xdotool", "key", "--window", win, "ctrl+o")
        wait_title(display, TITLE)
        time.sleep(1.5)
        dialog = x(display, "xdotool", "search", "--name", TITLE).split()[0]
        x(display, "xdotool", "windowfocus", "--sync", dialog)
        x(display, "xdotool", "key", "--window", dialog, "Escape")  # cancelled: nothing opens
        wait_status(info_file, "cancelled")
        x(display, "xdotool", "windowfocus", "--sync", win)
        x(display, "xdotool", "key", "--window", win, "ctrl+o")  # again, and this time a file
        wait_title(display, TITLE)
        time.sleep(1.5)  # zenity draws its chooser
        before = os.stat(info_file).st_mtime_ns
        time.sleep(1.0)
        assert os.stat(info_file).st_mtime_ns > before  # the window kept drawing under the dialog
        assert "choose in the dialog" in rects(info_file)["status"]
        dialog = x(display, "xdotool", "search", "--name", TITLE).split()[0]
        if os.environ.get("PUPPET_UPDATE_DOCS"):  # no window manager: place the dialog over the app
            x(display, "xdotool", "windowsize", dialog, "760", "520", "windowmove", dialog, "170", "140")
            time.sleep(1.0)
            shot = tmp_path / "dialog.png"
            screenshot(display, shot)
            subprocess.run(["convert", str(shot), "-crop", "1100x820+0+0", os.path.join(DOCS_SHOTS, "file-dialog.png")],
                           check=True)
        x(display, "xdotool", "windowfocus", "--sync", dialog)
        x(display, "xdotool", "key", "--window", dialog, "ctrl+l")
        time.sleep(0.5)
        x(display, "xdotool", "type", "--delay", "15", os.path.join(SCENES, "strips.json"))
        time.sleep(0.3)
        x(display, "xdotool", "key", "Return")
        wait_status(info_file, "opened strips.json")
        end = time.monotonic() + 30
        listed = tmp_path / "config" / "puppet" / "recent.json"
        while time.monotonic() < end and not listed.exists():  # noted in the frame after it showed
            time.sleep(0.2)
        recent = json.loads(listed.read_text())["recent"]
        assert recent == [os.path.join(SCENES, "strips.json")]
    finally:
        close(app)
