"""Content-keyed caches: every built part of a scene is stored under a fingerprint of
exactly the inputs it was built from, so an edit can never leave a stale part behind
(a changed input gives a new key, and the old entry is simply not asked for again)."""
from __future__ import annotations

import hashlib
import json
import os
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


def file_stamp(path: str | None):
    """What identifies a file's current content cheaply: path, size and modification time."""
    if path is None:
        return None
    try:
        st = os.stat(path)
    except OSError:
        return [path]
    return [path, st.st_size, st.st_mtime_ns]


class Memo:
    """Least-recently-used stores of built parts under content keys, one per kind of
    part, counting builds.

    ``builds[kind]`` counts how often a part of that kind was really built (not found),
    which is how tests prove that an edit rebuilt only what it touched.

    Safe to share between threads (the export's solver thread, the app's worker): the
    stores are changed under a lock; a build runs outside it, so two threads asking for
    the same missing part at once may both build it (the first one stored is kept).
    """

    def __init__(self, capacity: dict[str, int] | None = None, default: int = 64):
        self.capacity = dict(capacity or {})
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
        value = build()
        with self._lock:
            self.builds[kind] = self.builds.get(kind, 0) + 1
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
