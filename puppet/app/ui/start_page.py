"""The start page: what ``puppet app`` shows with no file open (Open..., the recent files,
the bundled examples as buttons; a file dropped on the window opens too)."""
from __future__ import annotations

import glob
import os

from imgui_bundle import imgui

from puppet.app.model import recent
from puppet.app.ui.widgets import button, note

#: the bundled example scenes (a source checkout or an editable install)
EXAMPLES = os.path.abspath(os.path.join(os.path.dirname(__file__), *[os.pardir] * 3, "assets", "scenes"))
WIDTH = 460.0
FLAGS = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_move
         | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings
         | imgui.WindowFlags_.always_auto_resize)


def examples() -> list[str]:
    """The example scenes shipped in ``assets/scenes`` (empty when not installed beside them)."""
    return sorted(glob.glob(os.path.join(EXAMPLES, "*.json")))


def shown(app) -> bool:
    """The start page shows when no scene is open or opening and no dialog is up."""
    return not app.snap.loaded and not app.busy and app.dialog is None


def draw(window) -> None:
    """The start page, centred over the canvas area."""
    app = window.app
    if not shown(app):
        return
    x, y, w, h = app.area
    imgui.set_next_window_pos(imgui.ImVec2(x + w / 2, y + max(h / 2, 40)), imgui.Cond_.always, imgui.ImVec2(0.5, 0.5))
    imgui.set_next_window_size_constraints(imgui.ImVec2(WIDTH, 0), imgui.ImVec2(WIDTH, max(h - 20, 100)))
    imgui.begin("##start", None, FLAGS)
    imgui.text("puppet")
    imgui.push_text_wrap_pos(imgui.get_cursor_pos_x() + WIDTH - 20)
    imgui.text_disabled("Open a scene, a picture (a new scene over it) or layered art (.psd .psb .ora .kra), "
                        "or drop one on this window.")
    imgui.pop_text_wrap_pos()
    if button("Open...", "choose a file (Ctrl+O)"):
        window.open_dialog("open")
    _list("Recent files", recent.existing(), window, "recent", full=True)
    _list("Examples", examples(), window, "example", full=False)
    imgui.end()


def _list(title: str, paths: list[str], window, tag: str, *, full: bool) -> None:
    imgui.spacing()
    imgui.separator_text(title)
    if not paths:
        imgui.text_disabled("none yet" if tag == "recent" else "not installed")
        return
    for i, path in enumerate(paths):
        label = os.path.basename(path)
        if button(f"{label}##{tag}{i}", path, small=False):
            window.open_scene(path)
        note(f"{tag}:{label}")
        if full:
            imgui.same_line()
            imgui.text_disabled(_short(os.path.dirname(path)))


def _short(folder: str, most: int = 38) -> str:
    home = os.path.expanduser("~")
    if folder.startswith(home + os.sep):
        folder = "~" + folder[len(home):]
    return folder if len(folder) <= most else "..." + folder[-most + 3:]
