"""Content-keyed caches: every built part of a scene is stored under a fingerprint of
exactly the inputs it was built from, so an edit can never leave a stale part behind
(a changed input gives a new key, and the old entry is simply not asked for again)."""
from __future__ import annotations

import hashlib
import json
import os
import stat
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np


def _plain(x: Any):
    """A JSON-able form of ``x`` (arrays as shape + hex digest of their bytes)."""
    if isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        return ["nd", str(a.dtype), list(a.shape), hashlib.blake2b(a.tobytes(), digest_size=16).hexdigest()]
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (np.integer, np.floating)):
        return x.item()
    if hasattr(x, "__dataclass_fields__"):
        return {k: _plain(getattr(x, k)) for k in x.__dataclass_fields__}
    return x


def fingerprint(*parts: Any) -> str:
    """A short stable digest of ``parts`` (JSON values, numpy arrays, dataclasses)."""
    text = json.dumps(_plain(parts), sort_keys=True, separators=(",", ":"), default=repr)
    return hashlib.blake2b(text.encode(), digest_size=16).hexdigest()


#: content digests of files by (path, device, inode, size, mtime, ctime), most recent last
_DIGESTS: OrderedDict[tuple, str] = OrderedDict()
_DIGESTS_LOCK = threading.Lock()


def file_stamp(path: str | None):
    """What identifies a file's current content: path, size and a digest of its bytes.

    The digest is read once per version of the file as ``stat`` tells it (size,
    modification and change times, inode): new bytes with the same size and a restored
    modification time still change the change time, so they are read again. Keys built
    from it may be trusted across processes (the disk cache, :mod:`puppet.scene.rig.disk`).
    """
    if path is None:
        return None
    try:
        st = os.stat(path)
    except OSError:
        return [path]
    if not stat.S_ISREG(st.st_mode):  # a FIFO or a device is never read here (reading could block
        return [path, st.st_size, st.st_mtime_ns]  # forever): the scene's checks refuse it
    version = (path, st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    with _DIGESTS_LOCK:
        digest = _DIGESTS.get(version)
    if digest is None:
        try:
            h = hashlib.blake2b(digest_size=16)
            with open(path, "rb") as f:
                while chunk := f.read(1 << 20):
                    h.update(chunk)
            digest = h.hexdigest()
        except (OSError, ValueError):
            return [path, st.st_size, st.st_mtime_ns]
        with _DIGESTS_LOCK:
            _DIGESTS[version] = digest
            while len(_DIGESTS) > 4096:
                _DIGESTS.popitem(last=False)
    return [path, st.st_size, digest]


class Memo:
    """Least-recently-used stores of built parts under content keys, one per kind of
    part, counting builds.

    ``builds[kind]`` counts how often a part of that kind was really built (not found
    in memory nor on disk), which is how tests prove that an edit rebuilt only what it
    touched. ``get`` asks memory, then the disk layer (when there is one and it keeps
    that kind), then builds and has what it built written to the disk layer (on its writer thread).

    Safe to share between threads (the export's solver thread, the app's worker): the
    stores are changed under a lock; a build runs outside it, so two threads asking for
    the same missing part at once may both build it (the first one stored is kept).
    """

    def __init__(self, capacity: dict[str, int] | None = None, default: int = 64, disk=None):
        self.capacity = dict(capacity or {})
        #: the disk layer (:class:`puppet.scene.rig.disk.DiskStore`) or None: asked after
        #: memory, before building; what is built is written to it
        self.disk = disk
        self.default = default
        self._stores: dict[str, OrderedDict[str, Any]] = {}
        self.builds: dict[str, int] = {}
        self._lock = threading.Lock()

    def get(self, kind: str, key: str, build: Callable[[], Any]) -> Any:
        with self._lock:
            store = self._stores.setdefault(kind, OrderedDict())
            if key in store:
                store.move_to_end(key)
                return store[key]
        disk = self.disk if self.disk is not None and self.disk.holds(kind) else None
        value = disk.load(kind, key) if disk is not None else None
        if value is None:
            value = build()
            with self._lock:
                self.builds[kind] = self.builds.get(kind, 0) + 1
            if disk is not None:
                disk.save_later(kind, key, value)
        with self._lock:
            if key in store:  # another thread built it meanwhile: keep one
                store.move_to_end(key)
                return store[key]
            store[key] = value
            while len(store) > self.capacity.get(kind, self.default):
                store.popitem(last=False)
        return value

    def at_least(self, kinds, n: int) -> None:
        """Keep at least ``n`` parts of each of ``kinds`` (a scene of many layers keeps one
        part per layer: a store smaller than that would rebuild every part every frame)."""
        with self._lock:
            for kind in kinds:
                self.capacity[kind] = max(self.capacity.get(kind, self.default), int(n))

    def count(self, kind: str) -> int:
        return self.builds.get(kind, 0)

    def clear(self) -> None:
        with self._lock:
            self._stores.clear()
