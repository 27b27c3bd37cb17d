"""Recent files of ``puppet app``: a small JSON list in the user's config folder.

``$XDG_CONFIG_HOME/puppet/recent.json`` (``~/.config/puppet/recent.json`` when
XDG_CONFIG_HOME is unset): ``{"recent": [path, ...]}``, newest first, at most
:data:`KEEP` absolute paths. Written atomically (a temporary file beside it, then a
rename), so two app windows never leave half a file; an unreadable or foreign file reads
as an empty list and is replaced on the next write.
"""
from __future__ import annotations

import json
import os
import tempfile

#: most recent files kept
KEEP = 10


def config_folder() -> str:
    """``$XDG_CONFIG_HOME/puppet`` or ``~/.config/puppet``."""
    base = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
    return os.path.join(base, "puppet")


def recent_file() -> str:
    return os.path.join(config_folder(), "recent.json")


def load() -> list[str]:
    """The recent files, newest first (an unreadable list reads as empty)."""
    try:
        with open(recent_file(), encoding="utf-8") as f:
            items = json.load(f).get("recent", [])
    except (OSError, ValueError, AttributeError):
        return []
    return [p for p in items if isinstance(p, str) and p][:KEEP]


def existing() -> list[str]:
    """The recent files that still exist (what the start page and File > Recent show)."""
    return [p for p in load() if os.path.isfile(p)]


def add(path: str) -> list[str]:
    """Put ``path`` (made absolute) first in the list and write it; returns the new list.
    A config folder that cannot be written changes nothing (recent files are a comfort,
    never an error)."""
    path = os.path.abspath(path)
    items = [path] + [p for p in load() if p != path]
    items = items[:KEEP]
    try:
        _write(items)
    except OSError:
        pass
    return items


def _write(items: list[str]) -> None:
    folder = config_folder()
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".recent.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({"recent": items}, f, indent=1)
        os.replace(tmp, recent_file())
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
