"""What every canvas tool shares: the pointer event, the drag threshold, and the pin
drag gesture (press on pins, drag, release) that both the pose tool and the animation
tools (:mod:`puppet.app.tools.anim`) run; and Pose mode's tool itself:

- :func:`pose_tool`: drag moves pins' targets in the active pose through a drag session
  (preview while moving, exact on release), Alt-drag around a pin turns it (the target's
  ``angle``) and selects it, Alt-click removes it, a click selects only that pin,
  Shift-click adds it to the selection or takes it out. Esc / Ctrl+Z during a gesture
  cancels it (:meth:`puppet.app.gl.window.AppWindow.cancel_gesture`).

A tool is a generator function over (app, event), like napari's mouse callbacks: called
with the press, sent each later event (``drag``, then ``release``) with ``gen.send``; it
returns after the release.
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


def moved(ev: CanvasEvent, press: CanvasEvent) -> bool:
    """The pointer is far enough from the press for a drag."""
    return math.hypot(ev.pos[0] - press.pos[0], ev.pos[1] - press.pos[1]) >= DRAG_THRESHOLD


def delta(app, ev: CanvasEvent, press: CanvasEvent) -> np.ndarray:
    """How far the pointer went since the press, in canvas pixels (2,)."""
    return (np.asarray(ev.pos) - np.asarray(press.pos)) / app.view.scale


def offset(start: dict, d) -> dict:
    """``start`` ({name: (x, y)}) moved by ``d``."""
    return {n: (xy[0] + d[0], xy[1] + d[1]) for n, xy in start.items()}


def click_or_drag(press: CanvasEvent):
    """Wait for the release; return (release event, whether the pointer moved)."""
    ev, went = press, False
    while ev.type != "release":
        ev = yield
        went = went or moved(ev, press)
    return ev, went


def explain_starch(app, press: CanvasEvent) -> None:
    """A press on a starch pin where only pose targets are picked: say why nothing follows."""
    starch = app.starch_at(press.pos)
    if starch is not None:
        app.say(f"{starch.name} is a starch pin: it holds no position (move it in Pin mode)")


def grab(app, press: CanvasEvent) -> dict | None:
    """Select the pin under the press (Shift: toggle it) and return the selected pins
    with where they are now, {name: (x, y)}; None when the press is beside the pins or
    Shift took the pin out of the selection."""
    m = app.marker_at(press.pos)
    if m is None:
        explain_starch(app, press)
        return None
    app.select(m.name, press.shift)
    if m.name not in app.selection:
        return None
    return {n: app.marker_xy(app.marker(n)) for n in app.selection if app.posable(n)}


def drag_pins(app, press: CanvasEvent, start: dict, *, time: float | None = None):
    """Drag the pins of ``start`` with the pointer through one drag session: nothing
    happens until the pointer leaves the press (a click never makes a pose); each move
    previews, the release commits the exact pose (``time``: keys the pins there).

    A generator for a tool to ``yield from``; returns the final positions, or None for a
    click.
    """
    ev, started, pos = press, False, dict(start)
    while ev.type != "release":
        ev = yield
        if not started and not moved(ev, press):
            continue
        if not started:
            started = True
            app.begin_drag(list(start), time=time)
        pos = offset(start, delta(app, ev, press))
        if ev.type != "release":
            app.move_drag(pos)
    if started:
        app.follow_pointer(pos)
        app.end_drag(pos)
    return pos if started else None


def drag_selection(app, press: CanvasEvent, *, time: float | None = None):
    """Press on a pin: it joins the selection (Shift toggles it) and a drag moves the
    selected pins (:func:`drag_pins`, ``time``: keys them there); a plain click selects
    only that pin, as in Photoshop. Returns the final positions, or None (a click, or a
    press beside the pins)."""
    m = app.marker_at(press.pos)
    start = grab(app, press)
    if start is None:
        return None
    pos = yield from drag_pins(app, press, start, time=time)
    if pos is None and not press.shift and m is not None:
        app.selection = [m.name]  # a plain click selects only that pin
    return pos


def remove_on_click(app, press, marker):
    ev, went = yield from click_or_drag(press)
    if not went:
        app.remove_pins([marker.name])
    return went


def pose_tool(app, press: CanvasEvent):
    m = app.marker_at(press.pos)
    if press.alt:
        if m is not None:
            yield from _rotate(app, press, m, click_removes=True)
            return
        near = app.marker_at(press.pos, radius=ROTATE_RADIUS)
        if near is not None:
            yield from _rotate(app, press, near, click_removes=False)
        return
    if m is None:
        if not press.shift:
            app.selection = []
        explain_starch(app, press)
        yield from click_or_drag(press)
        return
    yield from drag_selection(app, press)


def _rotate(app, press, m, *, click_removes: bool):
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
    elif click_removes:
        app.remove_pins([m.name])
    return ev, went
