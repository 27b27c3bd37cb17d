"""Keyboard shortcuts, read from ImGui's key state once a frame (so a text field that has
the keyboard keeps its keys). :data:`KEYS` is what the help overlay lists."""
from __future__ import annotations

from imgui_bundle import imgui

K = imgui.Key

#: (keys, what they do) as shown by the keys overlay (?)
KEYS = [
    ("Tab / 1 / 2", "switch Pin mode (edit pins at rest) / Pose mode (move pins in the active pose)"),
    ("click (Pin mode)", "add a pin on the layer under the cursor (or the selected layer)"),
    ("drag a pin", "move it (Pin mode: rest position; Pose mode: its target, live)"),
    ("Alt + drag near a pin", "turn it (Pose mode: the pose's angle for the pin)"),
    ("Alt + click a pin / Delete", "remove the pin(s)"),
    ("Shift + click", "add a pin to the selection (then drag moves them all)"),
    ("Arrows / Shift + Arrows", "nudge selected pins 1 px / 10 px"),
    ("[ / ]", "pin depth -1 / +1 (behind / in front)"),
    ("H", "hide / show pins"),
    ("M / D / L", "mesh wireframe / depth view / link segments"),
    ("wheel", "zoom about the cursor"),
    ("middle drag / Space + drag", "pan"),
    ("F / Home", "fit the canvas in the window"),
    ("Ctrl+1", "100 % zoom"),
    ("Ctrl+A / Esc", "select every pin / clear the selection"),
    ("K", "key: store the pose at the playhead (timeline)"),
    ("P / , / .", "play or pause / previous frame / next frame"),
    ("Shift + , / Shift + .", "previous key / next key"),
    ("click a key mark, Delete", "delete the selected keys (after a click in the timeline)"),
    ("Ctrl+C / Ctrl+V (timeline)", "copy the selected keys / paste them at the playhead"),
    ("Ctrl + drag a key mark", "copy the key to where it is dropped"),
    ("Ctrl+Z / Ctrl+Shift+Z, Ctrl+Y", "undo / redo"),
    ("Ctrl+S / Ctrl+Shift+S", "save / save as"),
    ("Ctrl+O", "open a scene"),
    ("Ctrl+E", "export the animation (File > Export)"),
    ("Ctrl+Q", "quit"),
    ("? / F1", "this list"),
]


def _pressed(key, repeat: bool = False) -> bool:
    return imgui.is_key_pressed(key, repeat)


def handle_keys(app, win) -> None:
    """Run the shortcut actions of this frame's key presses."""
    io = imgui.get_io()
    if app.dialog is not None:  # the dialog has the keys (Esc closes it there)
        return
    ctrl, shift = io.key_ctrl, io.key_shift
    typing = io.want_text_input  # a text field has the keyboard: only file and quit keys
    if ctrl:
        if _pressed(K.s):
            if shift:
                win.open_dialog("save_as")
            else:
                app.save()
        elif _pressed(K.o):
            win.open_dialog("open")
        elif _pressed(K.e):
            from puppet.app import export_dialog

            export_dialog.open_dialog(app)
        elif _pressed(K.q):
            app.request_quit()
        elif typing:
            pass
        elif _pressed(K.z, True):
            app.redo() if shift else app.undo()
        elif _pressed(K.y, True):
            app.redo()
        elif _pressed(K.a):
            app.selection = [m.name for m in app.markers()]
        elif _pressed(K.c) and app.timeline.focus:
            app.timeline.copy()
        elif _pressed(K.v) and app.timeline.focus:
            app.timeline.paste()
        elif _pressed(K._1):
            c = (app.area[0] + app.area[2] / 2, app.area[1] + app.area[3] / 2)
            app.view.zoom_at(c, 1.0 / app.view.scale)
        elif _pressed(K._0):
            app.fit()
        return
    if typing:
        return
    if "?" in win.input.chars or _pressed(K.f1):
        app.show_help = not app.show_help
    elif _pressed(K.escape):
        if app.show_help:
            app.show_help = False
        else:
            app.selection = []
    elif _pressed(K.tab) or _pressed(K._1) or _pressed(K._2):
        mode = "pin" if _pressed(K._1) else "pose" if _pressed(K._2) else ("pose" if app.mode == "pin" else "pin")
        app.set_mode(mode)
    elif _pressed(K.f) or _pressed(K.home):
        app.fit()
    elif _pressed(K.h):
        app.show_pins = not app.show_pins
    elif _pressed(K.m):
        app.show_mesh = not app.show_mesh
    elif _pressed(K.d):
        app.depth_view = not app.depth_view
    elif _pressed(K.l):
        app.show_links = not app.show_links
    elif (_pressed(K.delete) or _pressed(K.backspace)) and app.timeline.focus and app.timeline.selected:
        app.timeline.delete_keys()
    elif _pressed(K.k):
        app.timeline.add_key()
    elif _pressed(K.p):
        app.timeline.toggle_play()
    elif _pressed(K.comma, True):
        app.timeline.step_key(-1) if shift else app.timeline.step_frame(-1)
    elif _pressed(K.period, True):
        app.timeline.step_key(1) if shift else app.timeline.step_frame(1)
    elif _pressed(K.delete) or _pressed(K.backspace):
        if app.selection:
            app.remove_pins(list(app.selection))
    elif _pressed(K.left_bracket, True):
        app.change_depth(-1.0)
    elif _pressed(K.right_bracket, True):
        app.change_depth(+1.0)
    else:
        step = 10.0 if shift else 1.0
        for key, d in ((K.left_arrow, (-step, 0)), (K.right_arrow, (step, 0)),
                       (K.up_arrow, (0, -step)), (K.down_arrow, (0, step))):
            if _pressed(key, True):
                app.nudge(*d)
