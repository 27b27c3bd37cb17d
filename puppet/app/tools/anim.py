"""Canvas tools of the animation (Pose mode, the canvas showing the timeline's time):

- :func:`key_drag_tool`: dragging pins keys them at the playhead (After Effects keys a
  Puppet pin when it moves at a time): the pose at that time with the pins moved is
  previewed while dragging, and the release sets their targets in the key at the
  playhead (one undo step; a key already there keeps its other pins).
- :func:`record_tool` (Record on): Puppet Sketch. From the press, the playhead runs at the
  record speed and the pin's path is sampled in real time (also while the pointer
  rests); the release simplifies the path into keys (:func:`puppet.app.model.record.simplify_path`,
  the smoothing tolerance in canvas pixels) and stores them as keys of that pin, in one
  undo step, replacing the pin's keys inside the recorded span. The playhead goes back to
  where the recording began, so Play shows it at once.
"""
from __future__ import annotations

from puppet.app.model.record import Recording
from puppet.app.tools.gestures import delta, drag_selection, grab, moved, offset


def choose(app, press):
    """The Pose-mode tool when the timeline drives the canvas (None: the usual pose tool,
    also for a press beside the pins)."""
    t = app.timeline
    if press.alt:
        return None
    if app.marker_at(press.pos) is None:
        if t.record:
            app.say("Record is on: drag a pin to record its motion from the playhead", "error")
        return None
    if t.record:
        return record_tool
    if t.showing and t.anim is not None:
        return key_drag_tool
    return None


def key_drag_tool(app, press):
    t = app.timeline.time
    app.timeline.playing = False
    pos = yield from drag_selection(app, press, time=t)
    if pos is not None:
        app.timeline.selected = [t]


def record_tool(app, press):
    timeline = app.timeline
    clock = timeline.clock
    start = grab(app, press)
    if start is None:
        return
    timeline.playing = False
    t0 = timeline.time
    rec = Recording(t0, timeline.speed, clock())
    timeline.recording, timeline._rec_pos, timeline._rec_last = rec, dict(start), clock()
    rec.add(clock(), start)
    names = list(start)
    app.begin_drag(names, time=t0, record=True)
    app.say(f"recording {', '.join(names)} from {t0:.2f} s at {timeline.speed:g}x: release to stop")
    ev, went = press, False
    try:
        while ev.type != "release":
            ev = yield
            went = went or moved(ev, press)
            pos = offset(start, delta(app, ev, press))
            timeline._rec_pos = pos
            now = clock()
            t = rec.add(now, pos)
            timeline._rec_last = now
            timeline.time = t
            app.move_drag(pos, time=t)
    except GeneratorExit:  # cancelled (Esc): nothing recorded, the playhead back
        timeline.scrub(t0)
        raise
    finally:
        timeline.recording = None
        timeline.last_recording = rec
    keys = rec.keys(timeline.tolerance)
    if not went or len(keys) < 2:
        app.overrides = {}
        app.end_drag(None)
        if went:
            app.say("nothing recorded (hold the pin and move it while the playhead runs)", "error")
        else:  # a click records nothing (the playhead goes back); a plain one selects only that pin
            timeline.scrub(t0)
            m = app.marker_at(press.pos)
            if not press.shift and m is not None:
                app.selection = [m.name]
            app.say("Record is on: drag the selected pins to record their motion")
        return
    t1, tol = max(keys), timeline.tolerance
    app.end_drag(keys=keys, message=f"recorded {', '.join(names)}: {len(keys)} keys from {t0:.2f} to {t1:.2f} s "
                                    f"({len(rec.times)} samples, tolerance {tol:g} px)")
    timeline.selected = []
    timeline.showing = True
    timeline.scrub(t0)
