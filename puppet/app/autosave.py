"""Autosave: the scene with unsaved changes is written every minute beside its file as
``NAME.autosave.json`` (a valid scene), removed on save and on a normal exit; an autosave
newer than its scene at start means the app did not close normally, and it is offered
for recovery."""
from __future__ import annotations

import os

#: seconds between autosaves of a scene with unsaved changes
INTERVAL = 60.0


def path_for(scene_file: str) -> str:
    base, _ = os.path.splitext(scene_file)
    return base + ".autosave.json"


def write(scene) -> str:
    """Write ``scene`` (on the scene thread) to its autosave file; returns the path."""
    path = path_for(scene.file)
    scene.save(path)
    return path


def remove(scene_file: str | None) -> None:
    if not scene_file:
        return
    try:
        os.remove(path_for(scene_file))
    except FileNotFoundError:
        pass
    except OSError:  # read-only folder: nothing to clean
        pass


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
