"""While a canvas drag waits for the scene thread, the window draws input-only frames at
most DRAG_FPS times a second (each frame holds the GIL through its GL calls and starves the
solve), and still draws a new snapshot at once."""
from __future__ import annotations

import threading
import time

import pytest

from puppet.app.gl import window as window_mod

pytestmark = pytest.mark.gl


def _grab(d):
    """Pose 'bend' active, the right pin pressed and dragged a little; its screen point."""
    return d.grab("right", 4, pose="bend")


def _drag_frames(d, seconds: float, busy: bool) -> int:
    """Frames the loop draws while the pointer drags for ``seconds`` (``busy``: the scene
    thread holds a job the whole time)."""
    start = _grab(d)
    gate = threading.Event()
    if busy:
        d.app.session._post(lambda: gate.wait(30), publish=False)
        time.sleep(0.05)
        assert d.app.busy
    drawn, k, end = 0, 0, time.perf_counter() + seconds
    while time.perf_counter() < end:
        k += 1
        x, y = start[0] + (k % 7), start[1] - 4 - (k % 5)
        d.w.win.dispatch_event("on_mouse_drag", x, d._y(y), 1, 1, 1, 0)
        d.pos = (x, y)
        drawn += d.w.step()
        time.sleep(0.002)
    gate.set()
    d.settle()
    d.release()
    d.settle()
    return drawn


def test_a_drag_waiting_for_its_solve_draws_at_most_drag_fps(bar_app):
    d = bar_app
    seconds = 0.6
    drawn = _drag_frames(d, seconds, busy=True)
    # the first frame may come at once; then one per 1/DRAG_FPS at most, and one more 0.25 s tick
    assert 1 <= drawn <= seconds * window_mod.DRAG_FPS + 2, drawn
    assert window_mod.DRAG_FPS < window_mod.MAX_FPS


def test_a_new_snapshot_is_drawn_at_once_during_a_drag(bar_app):
    d = bar_app
    _grab(d)
    gate = threading.Event()
    d.app.session._post(lambda: gate.wait(30), publish=False)
    d.w.step()  # an input frame just drawn: the next input-only one is not due for 1/DRAG_FPS s
    d.app.session._post(lambda: None)  # publishes a snapshot once the gate opens
    gate.set()
    end = time.monotonic() + 10
    while not d.app.news and time.monotonic() < end:
        time.sleep(0.001)
    assert d.app.news
    assert d.w.step()  # drawn at once, whatever the pacing
    d.release()
    d.settle()
