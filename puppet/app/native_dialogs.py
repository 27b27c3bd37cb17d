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


class Pending:
    """A native dialog the window polls: ``kind`` is ``open`` or ``save_as``."""

    def __init__(self, kind: str, start: str):
        from imgui_bundle import portable_file_dialogs as pfd

        self.kind = kind
        if kind == "open":
            self.dialog = pfd.open_file("Open a scene or a picture", start, FILTERS)
        else:
            self.dialog = pfd.save_file("Save the scene as", start, ["Scenes", "*.json"])

    def poll(self) -> tuple[bool, str | None]:
        """(done, the chosen path or None when cancelled); (False, None) while it shows."""
        if not self.dialog.ready(0):
            return False, None
        result = self.dialog.result()
        if isinstance(result, (list, tuple)):
            result = result[0] if result else ""
        return True, (result or None)
