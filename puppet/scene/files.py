"""Pixels a scene owns before it is saved: masks painted and layer images repainted in
the app. Each is written once, as a PNG named by its content, into a folder of the
document's own (so undo can point back at an earlier one); saving the scene copies the
ones it still uses beside the scene file (``SCENE.files/``) and points the scene at them.
"""
from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
import weakref

import numpy as np

from puppet.output import atomic_write, save_png


class PendingFiles:
    """A temporary folder of content-named PNGs, removed with its owner."""

    def __init__(self):
        self._folder: str | None = None
        self._finalizer = None

    @property
    def folder(self) -> str:
        if self._folder is None:
            self._folder = tempfile.mkdtemp(prefix="puppet-pixels-")
            self._finalizer = weakref.finalize(self, shutil.rmtree, self._folder, True)
        return self._folder

    def add(self, rgba: np.ndarray, hint: str) -> str:
        """Write ``rgba`` ((h, w, 4) uint8) once under a name from ``hint`` and its content."""
        rgba = np.ascontiguousarray(rgba, np.uint8)
        digest = hashlib.blake2b(rgba.tobytes() + str(rgba.shape).encode(), digest_size=6).hexdigest()
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", hint).strip("._") or "image"
        path = os.path.join(self.folder, f"{stem}-{digest}.png")
        if not os.path.exists(path):
            save_png(path, rgba)
        return path

    def owns(self, path: str) -> bool:
        return self._folder is not None and os.path.dirname(path) == self._folder

    def publish(self, paths: set[str], scene_path: str, inputs=()) -> dict[str, str]:
        """Copy ``paths`` (owned files) beside the scene at ``scene_path``; returns old -> new."""
        if not paths:
            return {}
        stem = os.path.splitext(os.path.basename(scene_path))[0]
        folder = os.path.join(os.path.dirname(os.path.abspath(scene_path)), f"{stem}.files")
        os.makedirs(folder, exist_ok=True)
        moved = {}
        for p in sorted(paths):
            dest = os.path.join(folder, os.path.basename(p))
            if not os.path.exists(dest):
                atomic_write(dest, lambda tmp, p=p: shutil.copyfile(p, tmp), inputs=inputs)
            moved[p] = dest
        return moved


def mask_rgba(mask: np.ndarray) -> np.ndarray:
    """A boolean mask (h, w) as the RGBA PNG the scene format reads as a mask (alpha > 0)."""
    mask = np.asarray(mask, bool)
    out = np.zeros(mask.shape + (4,), np.uint8)
    out[mask] = 255
    return out
