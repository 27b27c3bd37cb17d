"""Menu bar, toolbar, status line, the modal dialogs (open, save as, unsaved changes,
recover an autosave) and the keys overlay."""
from __future__ import annotations

import os

from imgui_bundle import imgui

from puppet.app.model import recent
from puppet.app.ui import actions, export_dialog, retarget_dialog, room_dialog, script
from puppet.app.ui.widgets import button, toggle

ERROR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)


def menu_bar(app, win) -> float:
    """The main menu bar (File, Edit, View: the action table's items); returns its height."""
    if imgui.begin_main_menu_bar():
        for title in ("File", "Edit", "View"):
            if imgui.begin_menu(title):
                menu_items(app, win, title)
                imgui.end_menu()
        h = imgui.get_window_height()
        imgui.end_main_menu_bar()
        return h
    return 0.0


def menu_items(app, win, title: str) -> None:
    """The items of menu ``title`` (inside ``begin_menu``)."""
    for a in actions.ACTIONS:
        if a.menu != title:
            continue
        if a.separator:
            imgui.separator()
        if a.name == "save":  # File > Open Recent under Open
            recent_menu(win)
        label, enabled = a.label, a.enabled(app)
        if a.name in ("undo", "redo"):  # named after the step, greyed when there is none
            step = app.snap.undo_label if a.name == "undo" else app.snap.redo_label
            label, enabled = f"{label} {step or ''}", enabled and step is not None
        shortcut = a.keys.split(",")[0].split(" / ")[0]
        if a.checked is not None:
            clicked, _ = imgui.menu_item(label, shortcut, getattr(app, a.checked))
        else:
            clicked = imgui.menu_item_simple(label, shortcut, enabled=enabled)
        if clicked and enabled:
            a.run(app, win)


def recent_menu(win) -> None:
    """File > Open Recent (the recent files that still exist)."""
    paths = recent.existing()
    if imgui.begin_menu("Open Recent", bool(paths)):
        for i, path in enumerate(paths):
            if imgui.menu_item_simple(f"{os.path.basename(path)}##recent{i}"):
                win.open_scene(path)
            imgui.set_item_tooltip(path)
        imgui.end_menu()


def toolbar(app, wrap: bool = False) -> float:
    """Task-script steps, mode buttons and view toggles (inside the toolbar window); with
    ``wrap``, the view toggles and the buttons after them go on a second row. Returns the
    width all of it takes in one row (window pixels), to choose ``wrap`` next frame."""
    script.bar(app)
    imgui.text("|")
    imgui.same_line()
    broke = _mode_buttons(app, wrap)
    for name, label in (("pins", "pins"), ("mesh", "mesh"), ("depth", "depth"), ("links", "links")):
        a = actions.BY_NAME[name]
        setattr(app, a.checked, toggle(label, getattr(app, a.checked), actions.tip(name)))
        imgui.same_line()
    if button("Fit", actions.tip("fit")):
        app.fit()
    imgui.same_line()
    if button("Undo", actions.tip("undo", "undo " + (app.snap.undo_label or "")),
              enabled=app.snap.undo_label is not None):
        app.undo()
    imgui.same_line()
    if button("Redo", actions.tip("redo", "redo " + (app.snap.redo_label or "")),
              enabled=app.snap.redo_label is not None):
        app.redo()
    imgui.same_line()
    if button("?", actions.tip("help", "keys")):
        app.show_help = not app.show_help
    if app.snap.loaded:
        imgui.same_line()
        imgui.text_disabled("  " + shown_label(app))
    style = imgui.get_style()
    end = imgui.get_item_rect_max().x + style.window_padding.x
    if broke is None:
        return end
    return broke + 2 * style.item_spacing.x + imgui.calc_text_size("|").x + end - imgui.get_window_pos().x


def shown_label(app) -> str:
    """What the canvas shows, for the toolbar: the pose, the animation time, or while
    recording the playhead's time (it runs ahead of the shown snapshots)."""
    if app.timeline.recording is not None:
        return f"recording: {app.timeline.time:.2f} s"
    return f"pose: {app.snap.shown}"


def _mode_buttons(app, wrap: bool) -> float | None:
    """Pin mode / Pose mode and a separator; with ``wrap`` a new row starts after them
    (returns where the first row ended, None without ``wrap``)."""
    for mode in ("pin", "pose"):
        a = actions.BY_NAME[f"{mode}_mode"]
        active = app.mode == mode
        if active:
            imgui.push_style_color(imgui.Col_.button, imgui.ImVec4(0.2, 0.45, 0.8, 1.0))
        if button(a.label, actions.tip(a.name) + " or Tab"):
            app.set_mode(mode)
        if active:
            imgui.pop_style_color()
        if not wrap or mode == "pin":
            imgui.same_line()
    if wrap:
        return imgui.get_item_rect_max().x
    imgui.text("|")
    imgui.same_line()
    return None


def status_line(app, cursor_xy) -> None:
    """The last message (errors in red) and, at the right, pose, zoom, cursor position."""
    msg = app.status
    if msg is not None:
        if msg.level == "error":
            imgui.text_colored(ERROR, msg.text)
        else:
            imgui.text(msg.text)
    right = f"{'solving...  ' if app.busy else ''}zoom {app.view.scale * 100:.0f}%"
    if cursor_xy is not None:
        right += f"  x {cursor_xy[0]:.0f} y {cursor_xy[1]:.0f}"
    w = imgui.calc_text_size(right).x
    imgui.same_line(max(imgui.get_window_width() - w - 12, imgui.get_cursor_pos_x() + 20))
    imgui.text_disabled(right)


def dialogs(app, win) -> None:
    """The modal dialog the app asks for, if any."""
    kind = app.dialog
    if kind is None:
        return
    titles = {"open": "Open scene", "save_as": "Save scene as", "unsaved": "Unsaved changes",
              "recover": "Recover unsaved work", "export": "Export animation", "retarget": retarget_dialog.TITLE,
              "dressroom": room_dialog.TITLE}
    title = titles[kind]
    if not imgui.is_popup_open(title):
        imgui.open_popup(title)
    imgui.set_next_window_size(imgui.ImVec2(460, 0))
    opened, _ = imgui.begin_popup_modal(title, None, imgui.WindowFlags_.always_auto_resize)
    if not opened:
        return
    if kind in ("export", "retarget", "dressroom"):
        {"export": export_dialog, "retarget": retarget_dialog, "dressroom": room_dialog}[kind].draw(app)
        imgui.end_popup()
        return
    if kind != "recover" and imgui.is_key_pressed(imgui.Key.escape):
        app.dialog, app.after_dialog = None, None
        imgui.close_current_popup()
        imgui.end_popup()
        return
    if kind in ("open", "save_as"):
        _path_dialog(app, win, kind)
    elif kind == "unsaved":
        imgui.text_wrapped(f"Save the changes to {os.path.basename(app.snap.file or '')} first?")
        if button("Save", "save, then go on"):
            app.save()
            _close(app, win, proceed=True, saved=True)
        imgui.same_line()
        if button("Don't save", "lose the changes and go on"):
            _close(app, win, proceed=True)
        imgui.same_line()
        if button("Cancel", "keep working"):
            _close(app, win, proceed=False)
    elif kind == "recover":
        imgui.text_wrapped(f"An autosave newer than the scene was found:\n{app.recover_path}\n"
                           "(the app did not close normally). Recover it?")
        if button("Recover", "open the autosaved work (the scene file is unchanged until you save)"):
            win.recover(True)
            imgui.close_current_popup()
        imgui.same_line()
        if button("Discard", "open the scene as saved and delete the autosave"):
            win.recover(False)
            imgui.close_current_popup()
    imgui.end_popup()


def _path_dialog(app, win, kind: str) -> None:
    imgui.text("Scene file path:")
    imgui.set_next_item_width(440)
    if imgui.is_window_appearing():
        imgui.set_keyboard_focus_here()
    enter, app.path_field = imgui.input_text("##path", app.path_field, imgui.InputTextFlags_.enter_returns_true)
    imgui.set_item_tooltip("absolute, or relative to the folder the app was started in")
    go = enter or button("Open" if kind == "open" else "Save", "do it (Enter)")
    imgui.same_line()
    if button("Cancel", "close this dialog (Esc)"):
        app.dialog = None
        imgui.close_current_popup()
        return
    path = app.path_field.strip()
    if go and path:
        app.dialog = None
        imgui.close_current_popup()
        if kind == "open":
            win.open_scene(path)
        else:
            app.save(path if path.lower().endswith(".json") else path + ".json")


def _close(app, win, *, proceed: bool, saved: bool = False) -> None:
    after, app.after_dialog = app.after_dialog, None
    app.dialog = None
    imgui.close_current_popup()
    if proceed and after is not None:
        win.proceed(after, require_saved=saved)


def help_overlay(app) -> None:
    """The keys overlay (? / F1)."""
    if not app.show_help:
        return
    vp = imgui.get_main_viewport()
    imgui.set_next_window_pos(imgui.ImVec2(vp.size.x / 2, vp.size.y / 2), imgui.Cond_.always, imgui.ImVec2(0.5, 0.5))
    imgui.set_next_window_bg_alpha(0.92)
    opened, app.show_help = imgui.begin("Keys", True, imgui.WindowFlags_.always_auto_resize
                                        | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings)
    if opened:
        rows = actions.help_rows()
        half = (len(rows) + 1) // 2
        if imgui.begin_table("keys", 4, imgui.TableFlags_.row_bg):  # two columns of (keys, what)
            for k in range(half):
                imgui.table_next_row()
                for keys, what in rows[k::half]:
                    imgui.table_next_column()
                    imgui.text(keys)
                    imgui.table_next_column()
                    imgui.text(what)
            imgui.end_table()
        imgui.text_disabled("Press ? or Esc to close.")
    imgui.end()
