"""``puppet app``: an OpenGL window to pin, pose and arrange a puppet's layers.

Nothing in puppet imports this package (it sits on top of the import layers); the CLI
imports it lazily, so ``render`` and ``mesh`` never load pyglet or ImGui.
"""
from __future__ import annotations

import os


def run(path: str | None = None, *, size: tuple[int, int] = (1280, 800), headless: bool = False) -> int:
    """Open the app window (on ``path`` when given) and run it until it quits; returns 0."""
    import pyglet

    pyglet.options["debug_gl"] = False
    if headless:
        pyglet.options["headless"] = True
    elif not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        from puppet.errors import SceneError

        raise SceneError("puppet app needs a display (DISPLAY is not set; try xvfb-run -a -s "
                         "'-screen 0 1280x1024x24' puppet app ...)")
    from puppet.app.window import AppWindow, print_ready

    AppWindow(path, size=size, ready=print_ready).run()
    return 0
