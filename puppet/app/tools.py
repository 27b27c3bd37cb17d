"""Canvas tools: plain generator functions over (app, event), like napari's mouse drag
callbacks. A tool is called with the press event, and each later event (``drag``, then
``release``) is sent into it with ``gen.send(event)``; it returns after the release.

- :func:`pan_tool`: middle drag, or Space + drag.
- :func:`pin_tool` (Pin mode, the rest pose): click adds a pin, drag moves pins,
  Alt-click removes one, Shift-click extends the selection.
- :func:`pose_tool` (Pose mode): drag moves pins' targets in the active pose through a
  drag session (preview while moving, exact on release), Alt-drag around a pin turns
  it (the target's ``angle``), Alt-click removes it, Shift-click extends the selection.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: window pixels the pointer must travel before a press becomes a drag
DRAG_THRESHOLD = 3.0
#: Alt-press this close to a pin (window pixels) turns it
ROTATE_RADIUS = 80.0


@dataclass
class CanvasEvent:
    """A pointer event on the canvas: ``type`` is ``press``, ``drag`` or ``release``;
    ``pos`` is in window pixels (top-down), ``xy`` in canvas pixels."""

    type: str
    pos: tuple[float, float]
    xy: tuple[float, float]
    button: int = 0  # 0 left, 1 right, 2 middle
    shift: bool = False
    ctrl: bool = False
    alt: bool = False


def choose_tool(app, ev: CanvasEvent, space_down: bool = False):
    """The tool for a press: pan for the middle button or Space, else the mode's tool."""
    if ev.button == 2 or (ev.button == 0 and space_down):
        return pan_tool
    if ev.button != 0:
        return None
    step_tool = app.script.canvas_tool(app)  # the task script's mask, clone and link tools
    if step_tool is not None:
        return step_tool
    app.timeline.focus = False
    if app.mode == "pose":
        from puppet.app import animtools

        anim_tool = animtools.choose(app, ev)  # keying at the playhead, record mode
        if anim_tool is not None:
            return anim_tool
    return pin_tool if app.mode == "pin" else pose_tool


def _moved(ev: CanvasEvent, press: CanvasEvent) -> bool:
    return math.hypot(ev.pos[0] - press.pos[0], ev.pos[1] - press.pos[1]) >= DRAG_THRESHOLD


def _delta(app, ev: CanvasEvent, press: CanvasEvent) -> np.ndarray:
    return (np.asarray(ev.pos) - np.asarray(press.pos)) / app.view.scale


def pan_tool(app, ev: CanvasEvent):
    last = ev.pos
    while ev.type != "release":
        ev = yield
        app.view.pan(ev.pos[0] - last[0], ev.pos[1] - last[1])
        last = ev.pos


def _click_or_drag(press: CanvasEvent):
    """Wait for the release; return (release event, whether the pointer moved)."""
    ev, moved = press, False
    while ev.type != "release":
        ev = yield
        moved = moved or _moved(ev, press)
    return ev, moved


def _remove_on_click(app, press, marker):
    ev, moved = yield from _click_or_drag(press)
    if not moved:
        app.remove_pins([marker.name])
    return moved


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
    ev, moved = press, False
    while ev.type != "release":
        ev = yield
        moved = moved or _moved(ev, press)
        if moved:
            d = _delta(app, ev, press)
            app.overrides = {n: (xy[0] + d[0], xy[1] + d[1]) for n, xy in start.items()}
    if moved:
        app.move_pins(dict(app.overrides))
    elif m is None:
        app.overrides = {}


def pose_tool(app, press: CanvasEvent):
    m = app.marker_at(press.pos)
    if press.alt:
        if m is not None:
            ev, moved = yield from _rotate(app, press, m, remove_on_click=True)
            return
        near = app.marker_at(press.pos, radius=ROTATE_RADIUS)
        if near is not None:
            yield from _rotate(app, press, near, remove_on_click=False)
        return
    if m is None:
        if not press.shift:
            app.selection = []
        ev, moved = yield from _click_or_drag(press)
        return
    app.select(m.name, press.shift)
    if m.name not in app.selection:
        return
    names = [n for n in app.selection if app.marker(n) is not None]
    start = {n: app.marker_xy(app.marker(n)) for n in names}
    if len(names) == 1:
        yield from _drag_one(app, press, names[0], start[names[0]])
    else:
        yield from _drag_many(app, press, start)


def _drag_one(app, press, name, start):
    """One pin through the core's drag session: previews while moving, exact on release."""
    ev, started = press, False
    while ev.type != "release":
        ev = yield
        if not started and not _moved(ev, press):
            continue
        if not started:  # a click never makes a pose: start only on a real drag
            started = True
            app.worker.submit(lambda w: _start_drag(w, name), publish=False)
        d = _delta(app, ev, press)
        xy = (start[0] + d[0], start[1] + d[1])
        app.overrides = {name: xy}
        if ev.type != "release":
            app.worker.submit(_move_job(xy), key="drag-move", publish=False)
    if started:
        app.hold_markers(app.overrides, app.worker.submit(lambda w: _end_drag(w, xy)))


def _start_drag(w, name):
    if w.scene is None:
        return "no scene is open"
    w.drag = w.scene.drag(name)


def _move_job(xy):
    def job(w):
        if w.drag is not None and w.drag.open:
            w.publish(w.drag.move_layers(xy), preview=True)
    return job


def _end_drag(w, xy):
    d, w.drag = w.drag, None
    if d is None or not d.open:
        return None
    try:
        d.move_layers(xy)
        d.commit()
    except BaseException:
        d.cancel()
        raise


def drag_targets(app, press, start, preview):
    """Move the pins of ``start`` (name -> where they start) by the pointer until release,
    showing them at once and asking the worker for ``preview(pos)`` on each move.

    A generator for a tool to ``yield from``; returns the final positions, or None when the
    pointer never left the press (a click).
    """
    ev, moved = press, False
    pos = dict(start)
    while ev.type != "release":
        ev = yield
        moved = moved or _moved(ev, press)
        if not moved:
            continue
        d = _delta(app, ev, press)
        pos = {n: (xy[0] + d[0], xy[1] + d[1]) for n, xy in start.items()}
        app.overrides = dict(pos)
        if ev.type != "release":
            app.worker.submit(preview(pos), key="drag-move", publish=False)
    return pos if moved else None


def _drag_many(app, press, start):
    """Several pins: the pose with their new targets solved exactly per frame, one undo step."""
    pos = yield from drag_targets(app, press, start, _preview_job)
    if pos is not None:
        app.set_targets(pos)


def _preview_job(pos):
    def job(w):
        s = w.scene
        if s is None:
            return
        pose = s.to_dict().get("poses", {}).get(s.active_pose, {}) if s.active_pose != "rest" else {}
        for n, xy in pos.items():
            t = pose.get(n)
            pose[n] = dict(t, to=list(xy)) if isinstance(t, dict) else list(xy)
        w.publish(s.layers(pose), preview=True)
    return job


def _rotate(app, press, m, *, remove_on_click: bool):
    """Alt-drag around pin ``m``: its target angle in the active pose turns with the pointer
    (counter-clockwise on screen is positive); an Alt-click on the pin removes it."""
    centre = app.view.to_screen(app.marker_xy(m))
    a0 = app.target_angle(m.name)

    def screen_angle(pos):
        return math.degrees(math.atan2(-(pos[1] - centre[1]), pos[0] - centre[0]))

    last, total = screen_angle(press.pos), 0.0
    ev, moved = press, False
    while ev.type != "release":
        ev = yield
        if not moved and _moved(ev, press):
            moved = True
            app.begin_block("rotate", f"turn {m.name}")
        if not moved:
            continue
        a = screen_angle(ev.pos)
        total += (a - last + 180.0) % 360.0 - 180.0  # unwrapped: several turns add up
        last = a
        angle, name = a0 + total, m.name
        app.say(f"{name}: {angle:.1f}°")
        app.edit(lambda s, angle=angle: s.set_target(name, angle=angle) and None, key="rotate")
    if moved:
        app.end_block("rotate")
    elif remove_on_click:
        app.remove_pins([m.name])
    return ev, moved
