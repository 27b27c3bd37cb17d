"""The app's actions in one table: each :class:`Action` has its keys, its label, when it
is enabled and what it runs; the table drives the key dispatch (:func:`handle_keys`,
once a frame from ImGui's key state, so a text field that has the keyboard keeps its
keys), the menus (:func:`puppet.app.ui.menus.menu_items`), the toolbar's tooltips (:func:`tip`) and the keys
overlay (:func:`help_rows`). A shortcut is written once, here.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from imgui_bundle import imgui

from puppet.app.tools import deform as deformtools
from puppet.app.ui import export_dialog, retarget_dialog, room_dialog

K = imgui.Key


@dataclass(frozen=True)
class Action:
    """One thing the user can do.

    Attributes
    ----------
    name : str
        Id (menus and the toolbar look actions up by it).
    keys : str
        The shortcut as shown ("Ctrl+Shift+S"); empty for menu-only actions.
    label : str
        Menu label; :attr:`help` is the longer text of the keys overlay and tooltips.
    chords : tuple
        ``(imgui key, ctrl, shift)`` presses that run it (``shift`` None: either).
    run : callable
        ``run(app, win)``.
    enabled : callable
        ``enabled(app)``: whether it can run now (a disabled action's key is passed on
        to the next action with the same key).
    """

    name: str
    keys: str
    label: str
    help: str
    chords: tuple
    run: Callable
    enabled: Callable = lambda app: True
    menu: str | None = None  # "File", "Edit" or "View"
    checked: str | None = None  # an App attribute the menu item shows ticked
    separator: bool = False  # a menu separator before it
    repeat: bool = False  # key repeat runs it again
    typing: bool = False  # also while a text field has the keyboard
    char: str | None = None  # a typed character that runs it too ("?")


def _toggle(attr: str):
    def run(app, win):
        setattr(app, attr, not getattr(app, attr))
    return run


def _loaded(app) -> bool:
    return app.snap.loaded


def _export(app, win) -> None:
    export_dialog.open_dialog(app)


def _escape(app, win) -> None:
    st = deformtools.state(app)
    if app.show_help:
        app.show_help = False
    elif st.chain_draft:  # the chain tool's draft first
        st.chain_draft = []
        app.say("chain draft forgotten")
    else:
        app.selection = []


def _zoom_100(app, win) -> None:
    c = (app.area[0] + app.area[2] / 2, app.area[1] + app.area[3] / 2)
    app.view.zoom_at(c, 1.0 / app.view.scale)


def _nudge(app, win) -> None:
    step = 10.0 if imgui.get_io().key_shift else 1.0
    for key, d in ((K.left_arrow, (-step, 0)), (K.right_arrow, (step, 0)),
                   (K.up_arrow, (0, -step)), (K.down_arrow, (0, step))):
        if imgui.is_key_pressed(key, True):
            app.nudge(*d)


def _keys_selected(app) -> bool:
    return app.timeline.focus and bool(app.timeline.selected)


A = Action
#: every action, in the order of the keys overlay (and, per menu, of the menu)
ACTIONS: tuple[Action, ...] = (
    A("open", "Ctrl+O", "Open scene or picture...", "open a scene (or a picture as a new scene)",
      ((K.o, True, False),), lambda app, win: win.open_dialog("open"), menu="File", typing=True),
    A("save", "Ctrl+S", "Save", "save the scene", ((K.s, True, False),), lambda app, win: app.save(),
      _loaded, menu="File", typing=True),
    A("save_as", "Ctrl+Shift+S", "Save As...", "save as another file", ((K.s, True, True),),
      lambda app, win: win.open_dialog("save_as"), _loaded, menu="File", typing=True),
    A("export", "Ctrl+E", "Export animation...", "export the animation (video, GIF, frames)",
      ((K.e, True, None),), _export, _loaded, menu="File", typing=True),
    A("retarget", "", "Retarget motion...", "play a motion capture clip (.bvh) on the pins: the map of pins "
      "to joints is found and shown to correct; the keys replace the animation (one undo step)", (),
      lambda app, win: retarget_dialog.open_dialog(app), _loaded, menu="File"),
    A("dressroom", "", "Export dressing room...", "this scene as the mannequin and garment scenes on its canvas, "
      "written as a dressing room web page (puppet dressroom)", (), lambda app, win: room_dialog.open_dialog(app),
      _loaded, menu="File"),
    A("reload_art", "", "Reload art", "take the changed pixels of the art the scene was imported from "
      "(pins, poses and keys stay; one undo step)", (), lambda app, win: app.files.reload_art(),
      lambda app: app.snap.loaded and getattr(getattr(app, "files", None), "art", None) is not None,
      menu="File", separator=True),
    A("quit", "Ctrl+Q", "Quit", "quit (asks about unsaved changes)", ((K.q, True, None),),
      lambda app, win: app.request_quit(), menu="File", separator=True, typing=True),
    A("undo", "Ctrl+Z", "Undo", "undo", ((K.z, True, False),), lambda app, win: app.undo(), _loaded,
      menu="Edit", repeat=True),
    A("redo", "Ctrl+Shift+Z, Ctrl+Y", "Redo", "redo", ((K.z, True, True), (K.y, True, None)),
      lambda app, win: app.redo(), _loaded, menu="Edit", repeat=True),
    A("delete_keys", "Delete", "Delete selected keys", "delete the selected keys (after a click in the timeline)",
      ((K.delete, False, None), (K.backspace, False, None)), lambda app, win: app.timeline.delete_keys(),
      _keys_selected, menu="Edit", separator=True),
    A("remove_pins", "Delete", "Remove selected pins", "remove the selected pins (or Alt + click a pin)",
      ((K.delete, False, None), (K.backspace, False, None)),
      lambda app, win: deformtools.delete_selected(app) or app.remove_pins(list(app.selection)),
      lambda app: bool(app.selection), menu="Edit"),
    A("select_all", "Ctrl+A", "Select all pins", "select every pin", ((K.a, True, None),),
      lambda app, win: setattr(app, "selection", [m.name for m in app.markers()]), _loaded, menu="Edit"),
    A("escape", "Esc", "Clear the selection", "close this list / clear the selection", ((K.escape, False, None),),
      _escape),
    A("copy_keys", "Ctrl+C", "Copy keys", "copy the selected keys (after a click in the timeline)",
      ((K.c, True, None),), lambda app, win: app.timeline.copy(), lambda app: app.timeline.focus, menu="Edit",
      separator=True),
    A("paste_keys", "Ctrl+V", "Paste keys", "paste the copied keys at the playhead", ((K.v, True, None),),
      lambda app, win: app.timeline.paste(), lambda app: app.timeline.focus and bool(app.timeline.clipboard),
      menu="Edit"),
    A("pin_mode", "1", "Pin mode", "Pin mode: edit pins on the rest pose (click adds, drag moves)",
      ((K._1, False, None),), lambda app, win: app.set_mode("pin")),
    A("pose_mode", "2", "Pose mode", "Pose mode: drag pins to pose the puppet in the active pose",
      ((K._2, False, None),), lambda app, win: app.set_mode("pose")),
    A("switch_mode", "Tab", "Switch mode", "switch Pin mode / Pose mode", ((K.tab, False, None),),
      lambda app, win: app.set_mode("pose" if app.mode == "pin" else "pin")),
    A("fit", "F / Home", "Fit", "fit the canvas in the window", ((K.f, False, None), (K.home, False, None),
                                                                 (K._0, True, None)),
      lambda app, win: app.fit(), menu="View"),
    A("zoom_100", "Ctrl+1", "100 % zoom", "100 % zoom", ((K._1, True, None),), _zoom_100, menu="View"),
    A("pins", "H", "Pins", "hide / show pins", ((K.h, False, None),), _toggle("show_pins"), menu="View",
      checked="show_pins", separator=True),
    A("mesh", "M", "Mesh wireframe", "the deformed meshes over the canvas", ((K.m, False, None),),
      _toggle("show_mesh"), menu="View", checked="show_mesh"),
    A("depth", "D", "Depth view", "colour the layers by interpolated depth: blue back, red front",
      ((K.d, False, None),), _toggle("depth_view"), menu="View", checked="depth_view"),
    A("links", "L", "Link segments", "show link segments", ((K.l, False, None),), _toggle("show_links"),
      menu="View", checked="show_links"),
    A("stiffness", "", "Stiffness heat map", "the stiffness the solver sees, in red (Deform panel)", (),
      _toggle("show_stiffness"), menu="View", checked="show_stiffness"),
    A("cages", "", "Cages", "draw the layers' cages (Deform panel, cage tool)", (), _toggle("show_cages"),
      menu="View", checked="show_cages"),
    A("nudge", "Arrows / Shift + Arrows", "Nudge", "nudge the selected pins 1 px / 10 px",
      tuple((k, False, None) for k in (K.left_arrow, K.right_arrow, K.up_arrow, K.down_arrow)), _nudge,
      repeat=True),
    A("back", "[", "Back", "selected pins' depth -1: the region around them goes behind",
      ((K.left_bracket, False, None),), lambda app, win: app.change_depth(-1.0), repeat=True),
    A("front", "]", "Front", "selected pins' depth +1: the region around them comes in front",
      ((K.right_bracket, False, None),), lambda app, win: app.change_depth(+1.0), repeat=True),
    A("key", "K", "Key", "key: store the pose at the playhead (timeline)", ((K.k, False, None),),
      lambda app, win: app.timeline.add_key()),
    A("play", "P", "Play / Pause", "play or pause the animation from the playhead", ((K.p, False, None),),
      lambda app, win: app.timeline.toggle_play()),
    A("prev_frame", ",", "Previous frame", "previous frame", ((K.comma, False, False),),
      lambda app, win: app.timeline.step_frame(-1), repeat=True),
    A("next_frame", ".", "Next frame", "next frame", ((K.period, False, False),),
      lambda app, win: app.timeline.step_frame(1), repeat=True),
    A("prev_key", "Shift + ,", "Previous key", "previous key", ((K.comma, False, True),),
      lambda app, win: app.timeline.step_key(-1), repeat=True),
    A("next_key", "Shift + .", "Next key", "next key", ((K.period, False, True),),
      lambda app, win: app.timeline.step_key(1), repeat=True),
    A("help", "? / F1", "Keys", "this list", ((K.f1, False, None),), _toggle("show_help"), menu="View",
      checked="show_help", separator=True, char="?"),
)
BY_NAME = {a.name: a for a in ACTIONS}
#: actions that still run while a mouse button is held (they change only what is shown)
WHILE_HELD = frozenset({"mesh", "depth", "links", "help"})
#: pointer gestures, listed in the keys overlay after the actions
GESTURES = (
    ("click (Pin mode)", "add a pin on the layer under the cursor (or the selected layer)"),
    ("drag a pin", "move it (Pin mode: rest position; Pose mode: its target, live)"),
    ("click a pin", "select only that pin (a drag moves every selected pin)"),
    ("Shift + click", "add a pin to the selection, or take it out"),
    ("Alt + drag near a pin", "select and turn it (Pose mode: the pose's angle for the pin)"),
    ("Esc / Ctrl+Z while dragging", "cancel the drag (nothing changes)"),
    ("Alt + click a pin", "remove the pin"),
    ("wheel", "zoom about the cursor"),
    ("middle drag / Space + drag", "pan"),
    ("Ctrl + drag a key mark", "copy the key to where it is dropped"),
)


def tip(name: str, text: str | None = None) -> str:
    """A tooltip naming action ``name``'s keys: ``"TEXT (KEYS)"``."""
    a = BY_NAME[name]
    return f"{text or a.help} ({a.keys})" if a.keys else (text or a.help)


def help_rows() -> list[tuple[str, str]]:
    """(keys, what they do) for the keys overlay: the actions, then the gestures."""
    return [(a.keys, a.help) for a in ACTIONS if a.keys] + list(GESTURES)


def _pressed(a: Action, io, chars: str) -> bool:
    if a.char is not None and a.char in chars and not io.key_ctrl:
        return True
    return any(io.key_ctrl == ctrl and (shift is None or io.key_shift == shift) and imgui.is_key_pressed(k, a.repeat)
               for k, ctrl, shift in a.chords)


def handle_keys(app, win) -> Action | None:
    """Run the action of this frame's key press (the first enabled one with that key);
    returns it."""
    io = imgui.get_io()
    if app.dialog is not None or win.files.pending is not None:
        return None  # the dialog has the keys (Esc closes ours; a native one is a window of its own)
    typing = io.want_text_input  # a text field has the keyboard: only file and quit keys
    if win.gesture_held():  # a mouse button is down: Esc or Ctrl+Z cancels the drag, view keys only
        for a in ACTIONS:
            if (a.name in ("escape", "undo") or a.name in WHILE_HELD) and _pressed(a, io, win.input.chars):
                win.cancel_gesture() if a.name in ("escape", "undo") else a.run(app, win)
                return a
        return None
    for a in ACTIONS:
        if (a.typing or not typing) and _pressed(a, io, win.input.chars) and a.enabled(app):
            a.run(app, win)
            return a
    return None
