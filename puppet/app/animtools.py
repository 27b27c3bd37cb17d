"""Canvas tools of the animation (Pose mode, the canvas showing the timeline's time):

- :func:`key_drag_tool`: dragging pins keys them at the playhead (After Effects keys a
  Puppet pin when it moves at a time): the pose at that time with the pins moved is
  previewed while dragging, and the release sets their targets in the key at the
  playhead (one undo step; a key already there keeps its other pins).
- :func:`record_tool` (Record on): Puppet Sketch. From the press, the playhead runs at the
  record speed and the pin's path is sampled in real time (also while the pointer
  rests); the release simplifies the path into keys (:func:`puppet.app.record.simplify_path`,
  the smoothing tolerance in canvas pixels) and stores them as keys of that pin, in one
  undo step, replacing the pin's keys inside the recorded span. The playhead goes back to
  where the recording began, so Play shows it at once.
"""
from __future__ import annotations

from puppet.app import timeline as tl
from puppet.app.record import Recording
from puppet.app.tools import _delta, drag_targets, pose_tool


def choose(app, press):
    """The Pose-mode tool when the timeline drives the canvas (None: the usual pose tool)."""
    t = app.timeline
    if press.alt:
        return None
    if t.record:
        return record_tool
    if t.showing and t.anim is not None:
        return key_drag_tool
    return None


def _grab(app, press):
    """Pins the press grabs and where they start, or None (a click beside the pins)."""
    m = app.marker_at(press.pos)
    if m is None:
        return None
    app.select(m.name, press.shift)
    if m.name not in app.selection:
        return None
    names = [n for n in app.selection if app.marker(n) is not None]
    return {n: app.marker_xy(app.marker(n)) for n in names}


def key_drag_tool(app, press):
    start = _grab(app, press)
    if start is None:
        yield from pose_tool(app, press)  # a click beside the pins clears the selection
        return
    t = app.timeline.time
    app.timeline.playing = False
    pos = yield from drag_targets(app, press, start, lambda p: tl.preview_job(t, p))
    if pos is not None:
        label = f"key {', '.join(pos)} at {t:g} s"
        app.hold_markers(pos, app.timeline.key_pins(t, pos, label))
        app.timeline.selected = [t]


def record_tool(app, press):
    timeline = app.timeline
    clock = timeline.clock
    start = _grab(app, press)
    if start is None:
        app.say("Record is on: drag a pin to record its motion from the playhead", "error")
        yield from pose_tool(app, press)
        return
    timeline.playing = False
    t0 = timeline.time
    rec = Recording(t0, timeline.speed, clock())
    timeline.recording, timeline._rec_pos, timeline._rec_last = rec, dict(start), clock()
    rec.add(clock(), start)
    names = list(start)
    app.say(f"recording {', '.join(names)} from {t0:g} s at {timeline.speed:g}x: release to stop")
    ev = press
    try:
        while ev.type != "release":
            ev = yield
            d = _delta(app, ev, press)
            pos = {n: (xy[0] + d[0], xy[1] + d[1]) for n, xy in start.items()}
            timeline._rec_pos = pos
            now = clock()
            t = rec.add(now, pos)
            timeline._rec_last = now
            timeline.time = t
            app.overrides = dict(pos)
            app.worker.submit(tl.preview_job(t, pos), key="drag-move", publish=False)
    finally:
        timeline.recording = None
        timeline.last_recording = rec
    keys = rec.keys(timeline.tolerance)
    if len(keys) < 2:
        app.overrides = {}
        app.say("nothing recorded (hold the pin and move it while the playhead runs)", "error")
        return
    t1 = max(keys)
    tol = timeline.tolerance

    def fn(s):
        with s.block(f"record {', '.join(names)} {t0:g}-{t1:g} s"):
            if s.keys():
                tl.unkey_pins(s, names, t0, t1)
            for t, pins in keys.items():
                tl.merge_pins(s, t, pins)
        return (f"recorded {', '.join(names)}: {len(keys)} keys from {t0:g} to {t1:g} s "
                f"({len(rec.times)} samples, tolerance {tol:g} px)")
    app.hold_markers(app.overrides, app.edit(fn))
    timeline.selected = []
    timeline.showing = True
    timeline.scrub(t0)
