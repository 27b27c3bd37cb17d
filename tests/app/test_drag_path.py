"""The path of a pin drag through the code: from the window's mouse event to the solver
and back to the renderer, it crosses at most ten of the project's modules and one thread
hand-off each way (the window posts the move to the scene thread; the scene thread
publishes a snapshot that the window draws). Measured on the call stacks of a real drag
in the headless window, so a new hop (a module forwarding the drag, another queue) makes
this test fail."""
from __future__ import annotations

import os
import sys
import threading

import pytest
from pyglet.window import key

from tests.app.harness import Driver

pytestmark = pytest.mark.gl  # every test drives the app in a headless window (EGL)
PUPPET = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))) + os.sep + "puppet" + os.sep

#: where a stack is taken: the pyglet handler that takes the pointer, the window's post to
#: the scene thread, the solver's entry and the renderer's entry (its passes run the shaders)
MARKS = {("app/gl/keys.py", "on_mouse_drag"): "event", ("app/model/session.py", "move_drag"): "post",
         ("deform/arap.py", "arap_solve"): "solve", ("render/compositor.py", "draw"): "draw"}


class Stacks:
    """A profile hook on every thread: at each mark, the project modules on the stack (paths under puppet/)."""

    def __init__(self):
        self.on = False
        self.seen: dict[str, tuple[str, list[str]]] = {}

    def __call__(self, frame, event, arg):
        if not self.on or event != "call":
            return
        f = frame.f_code.co_filename
        if not f.startswith(PUPPET):
            return
        mark = MARKS.get((f[len(PUPPET):], frame.f_code.co_name))
        if mark is None or mark in self.seen:
            return
        files, fr = [], frame
        while fr is not None:
            name = fr.f_code.co_filename
            if name.startswith(PUPPET) and name[len(PUPPET):] not in files:
                files.append(name[len(PUPPET):])
            fr = fr.f_back
        self.seen[mark] = (threading.current_thread().name, files[::-1])


def test_a_pose_drag_crosses_ten_modules_and_one_hand_off(make_scene):
    from tests.conftest import bar_image, bar_scene

    stacks = Stacks()
    threading.setprofile(stacks)  # the scene thread starts with the window
    sys.setprofile(stacks)
    try:
        d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}), size=(1100, 700))
        start = d.grab("right", 6, pose="bend")
        stacks.on = True
        d.w.win.dispatch_event("on_mouse_drag", start[0], d._y(start[1] - 14), 0, -8, 1, 0)
        d.pos = (start[0], start[1] - 14)
        d.frame()
        d.settle()
        stacks.on = False
        d.release()
        d.settle()
        d.close()
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    assert set(stacks.seen) == {"event", "post", "solve", "draw"}, stacks.seen
    window = {stacks.seen[m][0] for m in ("event", "post", "draw")}
    solver_thread, solve_stack = stacks.seen["solve"]
    assert len(window) == 1 and solver_thread not in window  # the solve runs off the window's thread
    # the scene thread runs the solve itself: its stack starts in the session, no other queue
    assert solve_stack[0] == "app/model/session.py", solve_stack
    modules = []
    for mark in ("event", "post", "solve", "draw"):
        modules += [m for m in stacks.seen[mark][1] if m not in modules]
    # the argument checks every public method of a drag passes through first (a decorator,
    # docs/api.md "Argument errors"): a gate on the way in, not a hop that forwards the drag
    assert "scene/format/args.py" in modules
    modules.remove("scene/format/args.py")
    print("the drag's path:", " -> ".join(modules))
    assert len(modules) <= 10, modules
    for hop in ("app/tools/gestures.py", "app/model/app.py", "scene/drag/session.py", "app/gl/canvas.py"):
        assert hop in modules  # the path the docs describe (docs/app.md, How it works)
