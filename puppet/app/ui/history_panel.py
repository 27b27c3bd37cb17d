"""The History panel (as Photoshop's): the undo stack as a list, oldest first, under the
state the file was opened in; the current state is highlighted, undone steps (the redo
stack) are greyed below it. A click on a row undoes or redoes up to that state, one job
on the scene thread (:meth:`puppet.app.model.app.App.jump_history`); the steps stay, so a
click further down redoes them, until a new edit drops them, as Ctrl+Z / Ctrl+Y do."""
from __future__ import annotations

from imgui_bundle import imgui

from puppet.app.ui.widgets import note

#: the rows the panel shows at most before it scrolls
ROWS = 10


def rows(snap) -> list[tuple[str, int, bool]]:
    """(label, steps from the current state, undone) for each row: the opened state, every
    undo step (the last one is the current state, 0), then the redo steps (> 0)."""
    done, undone = list(snap.history), list(snap.future)
    out = [("(opened)", -len(done), False)]
    out += [(label, i + 1 - len(done), False) for i, label in enumerate(done)]
    out += [(label, i + 1, True) for i, label in enumerate(undone)]
    return out


def draw(app) -> None:
    """The panel's body (inside its collapsing header)."""
    items = rows(app.snap)
    style = imgui.get_style()
    grey = style.color_(imgui.Col_.text_disabled)
    height = min(len(items), ROWS) * imgui.get_text_line_height_with_spacing() + 2 * style.window_padding.y
    imgui.begin_child("##history", imgui.ImVec2(0, height), imgui.ChildFlags_.borders)
    for k, (label, steps, undone) in enumerate(items):
        if undone:
            imgui.push_style_color(imgui.Col_.text, grey)
        clicked, _ = imgui.selectable(f"{label}##history-{k}", steps == 0)
        if undone:
            imgui.pop_style_color()
        note(f"history:{k}")
        if clicked and steps:
            app.jump_history(steps)
    imgui.end_child()
