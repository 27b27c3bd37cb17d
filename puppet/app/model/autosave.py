"""Autosave: the scene with unsaved changes is written every minute beside its file as
``NAME.autosave.json`` (a valid scene), removed on save and on a normal exit; an autosave
newer than its scene at start means the app did not close normally, and it is offered
for recovery."""
from __future__ import annotations

import contextlib
import os
import re
import stat

from puppet.errors import SceneError
from puppet.output import OutputError
from puppet.scene.format.reader import parse_text, read_text

#: Names of the pixels files a save writes (:meth:`puppet.scene.document.files.PendingFiles.add`).
_PIXELS = re.compile(r"[A-Za-z0-9_.-]+-[0-9a-f]{12}\.png")
#: seconds between autosaves of a scene with unsaved changes
INTERVAL = 60.0


def path_for(scene_file: str) -> str:
    base, _ = os.path.splitext(scene_file)
    return base + ".autosave.json"


def files_for(scene_file: str) -> str:
    """The folder of the painted pixels an autosave holds (``NAME.autosave.files/``)."""
    return os.path.splitext(path_for(scene_file))[0] + ".files"


def write(scene) -> str:
    """Write ``scene`` (on the scene thread) to its autosave file; returns the path.

    A copy: the scene keeps reading its own pixels, so the next save writes them beside
    the scene, never pointing into ``NAME.autosave.files/``. Only an earlier autosave is
    replaced: any other file at that name (a picture, a link) is refused (OutputError).
    """
    path = path_for(scene.file)
    if os.path.lexists(path) and not is_autosave(path):
        raise OutputError(path, "is not an autosave of this app (it is kept; move it away to autosave)")
    scene.save(path, copy=True, follow=False)
    return path


def is_autosave(path: str) -> bool:
    """``path`` is a regular file (not a link) holding a scene: what :func:`write` writes."""
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return False
        raw = parse_text(read_text(path), path)
    except (OSError, SceneError):
        return False
    return isinstance(raw, dict) and raw.get("puppet") == 1 and isinstance(raw.get("layers"), list)


def remove(scene_file: str | None) -> None:
    """Delete the autosave of ``scene_file`` and its pixels, and nothing else: a file at
    that name that is not an autosave (see :func:`is_autosave`) is left alone, and from
    ``NAME.autosave.files/`` only the content-named PNGs the app writes."""
    if not scene_file:
        return
    path = path_for(scene_file)
    if is_autosave(path):
        with contextlib.suppress(OSError):  # read-only folder: nothing to clean
            os.remove(path)
    folder = files_for(scene_file)
    if os.path.islink(folder) or not os.path.isdir(folder):
        return
    with contextlib.suppress(OSError):
        for name in os.listdir(folder):
            p = os.path.join(folder, name)
            if _PIXELS.fullmatch(name) and stat.S_ISREG(os.lstat(p).st_mode):
                os.remove(p)
        os.rmdir(folder)  # only when nothing else is in it


def pending(scene_file: str) -> str | None:
    """The autosave of ``scene_file`` when it is newer than the scene (a crash), else None."""
    path = path_for(os.path.abspath(scene_file))
    try:
        auto = os.stat(path).st_mtime
    except OSError:
        return None
    try:
        saved = os.stat(scene_file).st_mtime
    except OSError:
        saved = 0.0
    return path if auto > saved else None
