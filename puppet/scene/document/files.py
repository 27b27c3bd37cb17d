"""Pixels a scene owns before it is saved: masks painted and layer images repainted in
the app. Each is written once, as a PNG named by its content, into a folder of the
document's own (so undo can point back at an earlier one); saving the scene copies the
ones it still uses beside the scene file (``SCENE.files/``) and points the scene at them.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import stat
import tempfile
import weakref
from collections.abc import Callable

import numpy as np

from puppet.output import OutputError, atomic_write, save_png


class PendingFiles:
    """A temporary folder of content-named PNGs, removed with its owner."""

    def __init__(self):
        self._folder: str | None = None
        self._finalizer = None
        self._staged: list[str] | None = None  # files written inside staged(), while it runs

    @contextlib.contextmanager
    def staged(self):
        """The files written inside (by :meth:`add`, :meth:`adopt`) are removed again when
        the block raises: an edit that is refused leaves no PNG behind. Nested blocks
        belong to the outermost one."""
        if self._staged is not None:
            yield
            return
        self._staged = []
        try:
            yield
        except BaseException:
            for p in self._staged:
                with contextlib.suppress(OSError):
                    os.remove(p)
            raise
        finally:
            self._staged = None

    def _wrote(self, path: str) -> None:
        if self._staged is not None:
            self._staged.append(path)

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
            self._wrote(path)
        return path

    def owns(self, path: str) -> bool:
        return self._folder is not None and os.path.dirname(path) == self._folder

    def adopt(self, path: str) -> str:
        """Take a copy of a saved pixels file (e.g. in ``NAME.autosave.files/``) as owned:
        the next save writes it beside its scene. Returns the owned path, or ``path`` itself
        when it is not a regular file (not read here: loading the scene reports it)."""
        dest = os.path.join(self.folder, os.path.basename(path))
        try:
            if not stat.S_ISREG(os.stat(path).st_mode):
                return path
            if not os.path.exists(dest):
                shutil.copyfile(path, dest)
                self._wrote(dest)
        except OSError:
            return path
        return dest

    def publish(self, paths: set[str], scene_path: str, inputs=()) -> tuple[dict[str, str], Callable[[], None]]:
        """Copy ``paths`` (owned files) beside the scene at ``scene_path``, into
        ``SCENE.files/``; returns (old -> new, undo). ``undo()`` removes what this call
        wrote (and the folder when it made it): the caller calls it when the scene itself
        cannot be written. On a failure here, the same is undone before raising.

        Files there are named by their content: one present already is kept when it is a
        regular file with these bytes; a link or a different file there is replaced only
        when it is a regular file (links are refused: :func:`puppet.output.check_file`).
        """
        if not paths:
            return {}, lambda: None
        stem = os.path.splitext(os.path.basename(scene_path))[0]
        folder = os.path.join(os.path.dirname(os.path.abspath(scene_path)), f"{stem}.files")
        if os.path.islink(folder):
            raise OutputError(folder, "is a symbolic link (puppet writes its files folder only as a real folder)")
        made = not os.path.lexists(folder)
        written: list[str] = []

        def undo() -> None:
            for p in written:
                with contextlib.suppress(OSError):
                    os.remove(p)
            if made:
                with contextlib.suppress(OSError):
                    os.rmdir(folder)
        moved = {}
        try:
            if made:
                os.mkdir(folder)
            for p in sorted(paths):
                dest = os.path.join(folder, os.path.basename(p))
                if not _same_bytes(p, dest):
                    atomic_write(dest, lambda tmp, p=p: shutil.copyfile(p, tmp), inputs=inputs, follow=False)
                    written.append(dest)
                moved[p] = dest
        except BaseException as e:
            undo()
            if isinstance(e, OSError) and not isinstance(e, OutputError):
                raise OutputError(folder, e.strerror or str(e)) from None
            raise
        return moved, undo


def _same_bytes(a: str, b: str) -> bool:
    """``b`` is a regular file (not a link) holding the bytes of ``a``."""
    try:
        st = os.lstat(b)
        if not stat.S_ISREG(st.st_mode) or st.st_size != os.path.getsize(a):
            return False
        with open(a, "rb") as fa, open(b, "rb") as fb:
            return fa.read() == fb.read()
    except OSError:
        return False


def mask_rgba(mask: np.ndarray) -> np.ndarray:
    """A boolean mask (h, w) as the RGBA PNG the scene format reads as a mask (alpha > 0)."""
    mask = np.asarray(mask, bool)
    out = np.zeros(mask.shape + (4,), np.uint8)
    out[mask] = 255
    return out
