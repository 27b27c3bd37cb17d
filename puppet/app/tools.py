"""Canvas tools: plain generator functions over (app, event), like napari's mouse drag
callbacks. A tool is called with the press event, and each later event (``drag``, then
``release``) is sent into it with ``gen.send(event)``; it returns after the release.

- :func:`pan_tool`: middle drag, or Space + drag.
- :func:`pin_tool` (Pin mode, the rest pose): click adds a pin, drag moves pins,
  Alt-click removes one, Shift-click extends the selection.
- :func:`pose_tool` (Pose mode): drag moves pins' targets in the active pose through a
  drag session (preview while moving, exact on release), Alt-drag around a pin turns
  it (the target's ``angle``) and selects it, Alt-click removes it, a click selects only
  that pin, Shift-click adds it to the selection or takes it out. Esc / Ctrl+Z during a
  gesture cancels it (:meth:`puppet.app.window.AppWindow.cancel_gesture`).
"""
from __future__ import annotations

import math

from puppet.app import animtools, deformtools
from puppet.app.gestures import CanvasEvent, click_or_drag, delta, drag_pins, explain_starch, grab, moved, offset

#: Alt-press this close to a pin (window pixels) turns it
ROTATE_RADIUS = 80.0


def choose_tool(app, ev: CanvasEvent, space_down: bool = False):
    """The tool for a press: pan for the middle button or Space, else the mode's tool."""
    if ev.button == 2 or (ev.button == 0 and space_down):
        return pan_tool
    if ev.button != 0:
        return None
    step_tool = app.script.canvas_tool(app)  # the task script's mask, clone and link tools
    if step_tool is not None:
        return step_tool
    deform_tool = deformtools.canvas_tool(app)  # stiffness brush, hinge, patch (Deform panel)
    if deform_tool is not None:
        return deform_tool
    app.timeline.focus = False
    if app.mode == "pose":
        anim_tool = animtools.choose(app, ev)  # keying at the playhead, record mode
        if anim_tool is not None:
            return anim_tool
    return pin_tool if app.mode == "pin" else pose_tool


def pan_tool(app, ev: CanvasEvent):
    last = ev.pos
    while ev.type != "release":
        ev = yield
        app.view.pan(ev.pos[0] - last[0], ev.pos[1] - last[1])
        last = ev.pos


def _remove_on_click(app, press, marker):
    ev, went = yield from click_or_drag(press)
    if not went:
        app.remove_pins([marker.name])
    return went


def pin_tool(app, press: CanvasEvent):
    m = app.marker_at(press.pos)
    if press.alt:
        if m is not None:
            if (yield from _remove_on_click(app, press, m)):
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


def pose_tool(app, press: CanvasEvent):
    m = app.marker_at(press.pos)
    if press.alt:
        if m is not None:
            yield from _rotate(app, press, m, remove_on_click=True)
            return
        near = app.marker_at(press.pos, radius=ROTATE_RADIUS)
        if near is not None:
            yield from _rotate(app, press, near, remove_on_click=False)
        return
    if m is None:
        if not press.shift:
            app.selection = []
        explain_starch(app, press)
        yield from click_or_drag(press)
        return
    start = grab(app, press)
    if start is not None:
        if (yield from drag_pins(app, press, start)) is None and not press.shift:
            app.selection = [m.name]  # a plain click selects only that pin


def _rotate(app, press, m, *, remove_on_click: bool):
    """Alt-drag around pin ``m``: its target angle in the active pose turns with the pointer
    (counter-clockwise on screen is positive); an Alt-click on the pin removes it."""
    centre = app.view.to_screen(app.marker_xy(m))
    a0 = app.target_angle(m.name)

    def screen_angle(pos):
        return math.degrees(math.atan2(-(pos[1] - centre[1]), pos[0] - centre[0]))

    last, total = screen_angle(press.pos), 0.0
    ev, went = press, False
    while ev.type != "release":
        ev = yield
        if not went and moved(ev, press):
            went = True
            app.selection = [m.name]  # the pin it turns is selected, as a click would
            app.begin_block("rotate", f"turn {m.name}")
        if not went:
            continue
        a = screen_angle(ev.pos)
        total += (a - last + 180.0) % 360.0 - 180.0  # unwrapped: several turns add up
        last = a
        angle, name = a0 + total, m.name
        app.say(f"{name}: {angle:.1f}°")
        app.edit(lambda s, angle=angle: s.set_target(name, angle=angle), key="rotate")
    if went:
        app.end_block("rotate")
    elif remove_on_click:
        app.remove_pins([m.name])
    return ev, went
