"""Native open / save dialogs (portable-file-dialogs, shipped with imgui-bundle: it runs
zenity, kdialog, matedialog or qarma on Linux). A dialog runs beside the window, which
keeps drawing and polls it once a frame; without a dialog program (or with
``PUPPET_NATIVE_DIALOGS=0``, and in headless windows) the app's own path field is used.
"""
from __future__ import annotations

import os
import shutil
import sys

#: the programs portable-file-dialogs uses on Linux
PROGRAMS = ("zenity", "kdialog", "matedialog", "qarma")
#: the file types offered (label, patterns), as portable-file-dialogs takes them
FILTERS = ["Scenes and pictures", "*.json *.png *.jpg *.jpeg *.bmp *.tif *.tiff *.webp",
           "Scenes", "*.json", "All files", "*"]


def available(headless: bool) -> bool:
    """Whether native dialogs can show here."""
    if headless or os.environ.get("PUPPET_NATIVE_DIALOGS", "1") == "0":
        return False
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and \
            any(shutil.which(p) for p in PROGRAMS)
    return True


#: what each kind of dialog asks: (title, save?, filters)
KINDS = {"open": ("Open a scene or a picture", False, FILTERS),
         "save_as": ("Save the scene as", True, ["Scenes", "*.json"]),
         "export": ("Export the animation to", True, ["Videos and pictures", "*.mp4 *.webm *.gif *.apng *.png",
                                                       "All files", "*"]),
         "picture": ("Reference picture", False, ["Pictures", "*.png *.jpg *.jpeg *.bmp *.tif *.tiff *.webp",
                                                  "All files", "*"])}
_pending: Pending | None = None


class Pending:
    """A native dialog showing; ``on_done(path)`` runs (on the window's thread, from
    :func:`poll`) when the user chose a file."""

    def __init__(self, kind: str, start: str, on_done):
        from imgui_bundle import portable_file_dialogs as pfd

        title, save, filters = KINDS[kind]
        self.kind, self.on_done = kind, on_done
        self.dialog = (pfd.save_file if save else pfd.open_file)(title, start, filters)

    def result(self) -> tuple[bool, str | None]:
        """(done, the chosen path or None when cancelled); (False, None) while it shows."""
        if not self.dialog.ready(0):
            return False, None
        result = self.dialog.result()
        if isinstance(result, (list, tuple)):
            result = result[0] if result else ""
        return True, (result or None)


def ask(kind: str, start: str, on_done) -> bool:
    """Show a native dialog of ``kind`` (see :data:`KINDS`) starting at ``start``; False
    when none can show here (use the path field). One at a time."""
    global _pending
    import pyglet

    if _pending is not None:
        return True
    if not available(bool(pyglet.options["headless"])):
        return False
    try:
        _pending = Pending(kind, start, on_done)
    except Exception:  # no dialog after all
        return False
    return True


def showing() -> bool:
    return _pending is not None


def poll() -> None:
    """Once a frame: hand a finished dialog's path to its ``on_done``."""
    global _pending
    if _pending is None:
        return
    done, path = _pending.result()
    if done:
        p, _pending = _pending, None
        if path is not None:
            p.on_done(path)
