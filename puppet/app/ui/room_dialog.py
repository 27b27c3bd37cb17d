"""The File > Export dressing room dialog (issue 34): the open scene is the mannequin; the
garment scenes are added by path (or Browse...) and listed with a remove button each; the
output is ROOM.html or a folder ROOM/; Export runs ``puppet dressroom`` in a child
(:mod:`puppet.app.model.room_export`) and the dialog says how it ended."""
from __future__ import annotations

import os

from imgui_bundle import imgui

from puppet.app.model import room_export
from puppet.app.ui.widgets import button, close_button, message, note

TITLE = "Export dressing room"
WIDTH = 440


def open_dialog(app) -> None:
    if not app.snap.loaded:
        return
    f = room_export.form(app)
    if not f.output:
        f.output = os.path.splitext(app.snap.file or os.path.join(os.getcwd(), "scene.json"))[0] + "-room.html"
    if not f.running:
        f.state, f.message = "idle", ""
    app.dialog = "dressroom"


def draw(app) -> None:
    """The dialog's body (inside the modal popup of :func:`puppet.app.ui.menus.dialogs`)."""
    f = room_export.form(app)
    imgui.begin_disabled(f.running)
    imgui.text_wrapped(f"Mannequin: {os.path.basename(app.snap.file or 'this scene')} as it is now (drawn at rest). "
                       "Garments: scenes on the same canvas, drawn at their pose 'fit':")
    for i, path in enumerate(list(f.garments)):
        if button(f"x##room-{i}", f"take {os.path.basename(path)} out of the room", small=True):
            f.garments.pop(i)
        imgui.same_line()
        imgui.text(os.path.basename(path))
        imgui.set_item_tooltip(path)
    files = getattr(app, "files", None)
    native = files is not None and files.native
    imgui.set_next_item_width(WIDTH - (150 if native else 60))
    if imgui.is_window_appearing():  # the dialog opens ready for the first garment's path
        imgui.set_keyboard_focus_here()
    entered, f.adding = imgui.input_text_with_hint("##room-garment", "a garment scene (.json)", f.adding,
                                                   imgui.InputTextFlags_.enter_returns_true)
    if entered:  # Enter adds and leaves the field: take the keyboard back, for the next path
        imgui.set_keyboard_focus_here(-1)
    imgui.set_item_tooltip("a garment scene's path (.json), then Add (or Enter)")
    note("room:garment")
    imgui.same_line()
    if button("Add##room", "add this garment scene to the room", enabled=bool(f.adding.strip())) or entered:
        why = f.add(f.adding)
        f.message, f.state = (why, "failed") if why else ("", "idle")
        if why is None:
            f.adding = ""
    if native:
        imgui.same_line()
        if button("Browse...##room", "choose a garment scene in a file dialog"):
            files.ask("open", lambda p: f.add(p), "")
    imgui.text("Write to (ROOM.html, one file; or a folder ROOM/ for a catalogue):")
    imgui.set_next_item_width(WIDTH)
    _, f.output = imgui.input_text("##room-output", f.output)
    note("room:output")
    imgui.end_disabled()
    if f.message:
        message(f.message, f.state == "failed", WIDTH)
    if f.running:
        imgui.text_disabled("writing the room (each garment drawn at its fit)...")
    elif button("Export##room", "write the dressing room's page", enabled=bool(f.garments and f.output.strip())):
        f.start(app)
        app.say(f"writing the dressing room to {f.output.strip()}...")
    imgui.same_line()
    close_button(app, "Close##room", f.message, f.state == "failed")
