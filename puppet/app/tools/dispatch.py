"""Canvas tools: plain generator functions over (app, event), like napari's mouse drag
callbacks. A tool is called with the press event, and each later event (``drag``, then
``release``) is sent into it with ``gen.send(event)``; it returns after the release.

- :func:`pan_tool`: middle drag, or Space + drag.
- :func:`pin_tool` (Pin mode, the rest pose): click adds a pin, drag moves pins,
  Alt-click removes one, Shift-click extends the selection.
- Pose mode's tool is :func:`puppet.app.tools.gestures.pose_tool`, beside the pin drag
  gesture it runs (so a pose drag goes through one module from the press to the App).
"""
from __future__ import annotations

from puppet.app.model.steps import TOOLS
from puppet.app.tools import anim as animtools
from puppet.app.tools import deform as deformtools
from puppet.app.tools import link as linkpencil
from puppet.app.tools import mask as masktools
from puppet.app.tools.gestures import (
    CanvasEvent,
    delta,
    moved,
    offset,
    pose_tool,
    remove_on_click,
)


def choose_tool(app, ev: CanvasEvent, space_down: bool = False):
    """The tool for a press: pan for the middle button or Space, else the mode's tool."""
    if ev.button == 2 or (ev.button == 0 and space_down):
        return pan_tool
    if ev.button == 1 and deformtools.sync(app) == "cage" and app.mode == "pin":
        return deformtools.cage_tool  # a right click deletes a cage vertex
    if ev.button != 0:
        return None
    tool = step_tool(app)  # the task script's mask, clone and link tools
    if tool is not None:
        return tool
    deform_tool = deformtools.canvas_tool(app)  # stiffness brush, hinge, patch (Deform panel)
    if deform_tool is not None:
        return deform_tool
    app.timeline.focus = False
    if app.mode == "pose":
        anim_tool = animtools.choose(app, ev)  # keying at the playhead, record mode
        if anim_tool is not None:
            return anim_tool
    return pin_tool if app.mode == "pin" else pose_tool


def step_tool(app):
    """The task script's tool for a left press in its step (None: the mode's)."""
    sc = app.script
    t = sc.tool if sc.step in TOOLS else None
    if t in ("brush-add", "brush-sub", "clone-brush", "erase", "paint"):
        return masktools.brush_tool
    if t == "lasso":
        return masktools.lasso_tool
    if t in ("clone-rect", "grabcut"):
        return masktools.rect_tool
    if t == "link":
        return linkpencil.link_tool
    return None


def pan_tool(app, ev: CanvasEvent):
    last = ev.pos
    while ev.type != "release":
        ev = yield
        app.view.pan(ev.pos[0] - last[0], ev.pos[1] - last[1])
        last = ev.pos


def pin_tool(app, press: CanvasEvent):
    m = app.marker_at(press.pos)
    if press.alt:
        if m is not None:
            if (yield from remove_on_click(app, press, m)):
                app.say("pins turn in Pose mode (an angle belongs to a pose)")
        return
    if m is None:
        name = app.add_pin_at(press.xy)
        if name is None:
            return
        start = {name: tuple(press.xy)}
    elif m.kind == "auto":
        app.select(m.name, press.shift)
        app.say(f"{m.name} is an automatic exterior point: move it in Pose mode")
        return
    else:
        app.select(m.name, press.shift)
        if m.name not in app.selection:
            return
        start = {n: app.marker_xy(mk) for n in app.selection
                 if (mk := app.marker(n)) is not None and mk.kind != "auto"}
    ev, went = press, False
    while ev.type != "release":
        ev = yield
        went = went or moved(ev, press)
        if went:
            app.follow_pointer(offset(start, delta(app, ev, press)))
    if went:
        app.move_pins(dict(app.overrides))
    elif m is None:
        app.overrides = {}
    elif not press.shift:
        app.selection = [m.name]  # a plain click selects only that pin
