"""``puppet app``: open the window on a file (or the start page) and run it until it quits.

pyglet is imported only here, inside :func:`run`, after its options (headless, no GL
debug) are set: its window module opens the display as it loads.
"""
from __future__ import annotations

import os

from puppet.app.model import opening
from puppet.errors import SceneError


def run(path: str | None = None, *, size: tuple[int, int] = (1280, 800), headless: bool = False) -> int:
    """Open the app window (on ``path`` when given) and run it until it quits; returns 0.

    ``path`` (a scene, a picture or layered art) is loaded before the window opens: one
    that cannot be opened raises SceneError (the CLI's one line, exit 2) with no window."""
    if path is not None:
        path = opening.preload(path)
    import pyglet  # lazy: options must be set before pyglet's window module loads

    pyglet.options["debug_gl"] = False
    if headless:
        pyglet.options["headless"] = True
    elif not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise SceneError("puppet app needs a display (DISPLAY is not set; try xvfb-run -a -s "
                         "'-screen 0 1280x1024x24' puppet app ...)")
    else:
        _connect_display()
    from puppet.app.gl.window import (  # lazy: loads pyglet.window (after the options)
        AppWindow,
        print_ready,
    )

    AppWindow(path, size=size, ready=print_ready).run()
    return 0


def _connect_display() -> None:
    """Open the display named by DISPLAY now: one line (SceneError) when no server answers
    there, instead of pyglet's NoSuchDisplayException from deep in the window's making."""
    import pyglet  # lazy: as in run()

    module = getattr(pyglet, "display", None) or pyglet.canvas  # pyglet 2.1 renamed canvas
    try:
        module.get_display()
    except Exception as e:
        if type(e).__name__ != "NoSuchDisplayException":
            raise
        raise SceneError(f"puppet app cannot open the display {os.environ.get('DISPLAY', '')!r} (no X server "
                         "answers there); check DISPLAY, or try xvfb-run -a -s '-screen 0 1280x1024x24' "
                         "puppet app ...") from None
