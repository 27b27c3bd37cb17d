"""Recent files and the start page.

The scenes the app opened or saved last (newest first, at most :data:`LIMIT`, only
files that still exist) are kept in a small JSON list, by default
``$XDG_CONFIG_HOME/puppet/recent.json`` (``~/.config/puppet/recent.json``); the window
keeps it only when given that path (``puppet app`` does; tests pass their own or none).
File > Open Recent lists them, and the start page (the canvas area when no scene is open)
shows them with the bundled example scenes.
"""
from __future__ import annotations

import json
import os

from imgui_bundle import imgui

from puppet.app.widgets import button, note

#: how many recent files are kept
LIMIT = 10
#: the bundled example scenes (in a source checkout)
EXAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        "assets", "scenes")


def default_path() -> str:
    base = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
    return os.path.join(base, "puppet", "recent.json")


def load(store: str | None) -> list[str]:
    """The recent files kept in ``store`` that still exist, newest first ([] without one)."""
    if not store:
        return []
    try:
        with open(store) as f:
            items = json.load(f)
    except (OSError, ValueError):
        return []
    return [p for p in items if isinstance(p, str) and os.path.isfile(p)][:LIMIT] if isinstance(items, list) else []


def add(store: str | None, path: str) -> None:
    """Put ``path`` first in ``store`` (written atomically; a store that cannot be
    written is left alone: recent files are a convenience)."""
    if not store:
        return
    path = os.path.abspath(path)
    items = [path] + [p for p in load(store) if p != path]
    try:
        os.makedirs(os.path.dirname(store), exist_ok=True)
        tmp = store + ".tmp"
        with open(tmp, "w") as f:
            json.dump(items[:LIMIT], f, indent=1)
        os.replace(tmp, store)
    except OSError:
        pass


def examples() -> list[str]:
    """The bundled example scenes, by name ([] outside a source checkout)."""
    if not os.path.isdir(EXAMPLES):
        return []
    return sorted(os.path.join(EXAMPLES, n) for n in os.listdir(EXAMPLES)
                  if n.endswith(".json") and not n.endswith(".autosave.json"))


def menu(win) -> None:
    """File > Open Recent (inside the File menu)."""
    items = load(win.recent_file)
    if imgui.begin_menu("Open Recent", bool(items)):
        for p in items:
            if imgui.menu_item_simple(os.path.basename(p), os.path.dirname(p)[-30:]):
                win.open_scene(p)
        imgui.end_menu()


def start_page(app, win) -> None:
    """The canvas area without a scene: Open..., the recent files and the examples."""
    x, y, w, h = app.area
    imgui.set_next_window_pos(imgui.ImVec2(x + w / 2, y + h / 2), 0, imgui.ImVec2(0.5, 0.5))
    imgui.set_next_window_size_constraints(imgui.ImVec2(320, 0), imgui.ImVec2(max(w - 40, 320), max(h - 40, 200)))
    imgui.begin("Start", None, imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings
                | imgui.WindowFlags_.always_auto_resize | imgui.WindowFlags_.no_move)
    if button("Open a scene or a picture...", "open a scene, or a picture as a new scene (Ctrl+O)"):
        win.open_dialog("open")
    note("start:open")
    imgui.text_disabled("or drop one on the window")
    for title, paths in (("Recent", load(win.recent_file)), ("Examples", examples())):
        if not paths:
            continue
        imgui.separator_text(title)
        for p in paths:
            name = os.path.basename(p)
            if imgui.selectable(f"{name}##{title}-{p}", False)[0]:
                win.open_scene(p)
            imgui.set_item_tooltip(p)
            note(f"start:{title.lower()}:{name}")
    imgui.end()
