"""Files in the app: native file dialogs (polled, the window keeps drawing), the plain
path field when no dialog program exists, recent files, files dropped on the window,
and "Reload art" when the art a scene was imported from changed on disk.

Native dialogs are imgui-bundle's portable-file-dialogs: the dialog program (zenity,
matedialog, qarma or kdialog on Linux; the system's own on macOS and Windows) runs in a
child process and :meth:`Files.poll` asks it each frame whether the user answered.
``PUPPET_FILE_DIALOG=field`` always uses the app's own path field instead (the tests set
it: a native dialog cannot be clicked by a test); ``=native`` forces the native one.
"""
from __future__ import annotations

import os
import shutil
import sys
import time

from puppet.app.model import recent
from puppet.app.model.opening import PICTURES
from puppet.imaging.layered import SUFFIXES as ART
from puppet.scene.make.art import art_of, stamp
from puppet.scene.make.reload import reload_art

#: the environment variable that picks the dialogs: "field", "native", or unset (native
#: when a dialog program is there)
ENV = "PUPPET_FILE_DIALOG"
#: dialog programs portable-file-dialogs runs on Linux
PROGRAMS = ("zenity", "matedialog", "qarma", "kdialog")
#: filters per dialog kind: (label, patterns) pairs
FILTERS = {
    "open": ["Scenes, pictures, layered art", " ".join("*" + e for e in (".json", *PICTURES, *ART)),
             "All files", "*"],
    "save_as": ["Scenes (.json)", "*.json"],
    "export": ["Video, GIF, frames", "*.mp4 *.webm *.mov *.gif *.apng *.png", "All files", "*"],
    "picture": ["Pictures", " ".join("*" + e for e in PICTURES), "All files", "*"],
    "motion": ["Motion capture (.bvh)", "*.bvh", "All files", "*"],
}
TITLES = {"open": "Open a scene, picture or layered art", "save_as": "Save scene as",
          "export": "Export animation to", "picture": "Reference picture", "motion": "Motion capture clip"}
#: seconds between two looks at the art file's date
ART_POLL = 1.0


def native_available() -> bool:
    """Whether a native file dialog can be shown here (see :data:`ENV`)."""
    mode = os.environ.get(ENV, "").strip().lower()
    if mode in ("field", "native"):
        return mode == "native"
    import pyglet

    if pyglet.options["headless"]:
        return False
    if sys.platform in ("win32", "darwin"):
        return True
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    return any(shutil.which(p) for p in PROGRAMS)


def _start(kind: str, default: str):
    """Open the native dialog of ``kind`` (returns its handle at once: it runs in a child)."""
    from imgui_bundle import portable_file_dialogs as pfd

    if kind in ("save_as", "export"):
        return pfd.save_file(TITLES[kind], default, FILTERS[kind])
    return pfd.open_file(TITLES[kind], default, FILTERS[kind])


def _answer(handle) -> str | None:
    """The path chosen in a finished dialog, or None when it was cancelled."""
    out = handle.result()
    if isinstance(out, (list, tuple)):
        out = out[0] if out else ""
    return out or None


class Files:
    """The window's file dialogs, recent files, drops and the art watch.

    Parameters
    ----------
    app : App
    window : AppWindow (its ``open_scene`` opens a file asking about unsaved changes)
    native : bool, optional
        Use native dialogs (default: :func:`native_available`).
    """

    def __init__(self, app, window, native: bool | None = None):
        self.app, self.window = app, window
        self.native = native_available() if native is None else native
        self.pending = None  # (handle, then) of the native dialog that is open
        self.art: str | None = None  # the open scene's art file, if it names one
        self.art_stamp = None  # its (mtime, size) when the scene was loaded or reloaded
        self.art_changed = False
        self._file = None
        self._reopen = False
        self._looked = 0.0

    # -- dialogs ----------------------------------------------------------------------
    def ask(self, kind: str, then, default: str = "") -> bool:
        """Show the native dialog of ``kind`` ("open", "save_as", "export", "picture") and
        call ``then(path)`` when the user has chosen. False when there is no native dialog
        (the caller shows its path field); True also when one is open already (the user
        is told to answer it first)."""
        if not self.native:
            return False
        if self.pending is not None:
            self.app.say("a file dialog is open already: answer it first")
            return True
        try:
            handle = _start(kind, default)
        except Exception as e:  # noqa: BLE001  (no dialog program after all: use the field)
            self.native = False
            self.app.say(f"no file dialog ({e}); type the path instead", "error")
            return False
        self.pending = (handle, then)
        self.app.say(f"{TITLES[kind]}: choose in the dialog window")
        return True

    def poll(self) -> None:
        """Once a frame: a dialog's answer, the recent files, the art's date."""
        if self.pending is not None:
            handle, then = self.pending
            if handle.ready(0):
                self.pending = None
                path = _answer(handle)
                if path:
                    self.app.say(f"chose {path}")  # (open and save say more once done)
                    then(path)
                else:
                    self.app.say("cancelled")
        self._note_file()
        self._watch_art()

    def cancel(self) -> None:
        """Close an open native dialog (the window is closing)."""
        if self.pending is not None:
            self.pending[0].kill()
            self.pending = None

    # -- recent files and drops -------------------------------------------------------
    def _note_file(self) -> None:
        snap = self.app.snap
        f = snap.file if snap.loaded else None
        again = self._reopen and not self.app.busy  # the same file opened again has loaded
        if f == self._file and not again:
            return
        if f is None or os.path.isfile(f):  # a new scene over a picture: noted once saved
            self._file, self._reopen = f, self._reopen and not again
            if f is not None:
                recent.add(f)
                self._art_loaded(snap)

    def reopening(self) -> None:
        """A file is being opened: look at its art again even if it is the same scene
        file (opened again after its art changed)."""
        self._reopen = True

    def on_drop(self, x, y, paths) -> None:
        """pyglet's ``on_file_drop``: open the first file dropped (a scene, a picture or
        layered art), asking about unsaved changes first; any other file is refused."""
        paths = [os.fspath(p) for p in paths if p]
        if not paths:
            return
        if os.path.splitext(paths[0])[1].lower() not in (".json", *PICTURES, *ART):
            self.app.say(f"{os.path.basename(paths[0])}: drop a scene (.json), a picture (PNG, JPEG, ...) or "
                         "layered art (.psd .psb .ora .kra) here", "error")
            return
        if len(paths) > 1:
            self.app.say(f"{len(paths)} files dropped: opening the first, {os.path.basename(paths[0])}")
        self.window.open_scene(paths[0])

    # -- Reload art -------------------------------------------------------------------
    def _art_loaded(self, snap) -> None:
        raw = getattr(snap.data, "raw", None)
        self.art = art_of(raw, snap.file) if isinstance(raw, dict) else None
        self.art_stamp = stamp(self.art)
        # art saved after the scene was: changed since the scene last took its pixels
        scene_st = stamp(snap.file)
        self.art_changed = bool(self.art_stamp and scene_st and self.art_stamp[0] > scene_st[0])
        if self.art_changed:
            self._hint()

    def _watch_art(self) -> None:
        if self.art is None or self.art_changed:
            return
        now = time.monotonic()
        if now - self._looked < ART_POLL:
            return
        self._looked = now
        st = stamp(self.art)
        if st is not None and st != self.art_stamp:
            self.art_changed = True
            self._hint()

    def _hint(self) -> None:
        self.app.say(f"{os.path.basename(self.art)} changed on disk: File > Reload art takes the new pixels "
                     "(pins, poses and keys stay)")

    def reload_art(self) -> None:
        """File > Reload art: the art merged into the open scene on the scene thread, one
        undo step; the status line lists what moved or went."""
        if self.art is None:
            return
        self.art_stamp, self.art_changed = stamp(self.art), False
        self.app.edit(_reload_job)


def _reload_job(scene) -> str:
    """The scene-thread half of Reload art: returns the status line (what was replaced,
    added, removed, and the merge's notes: pins moved inside their layer, pins and links
    removed)."""
    res = reload_art(scene)
    line = (f"reloaded the art: {len(res.replaced)} replaced, {len(res.added)} added, "
            f"{len(res.removed)} removed")
    return line + ("; " + "; ".join(res.notes) if res.notes else "")
