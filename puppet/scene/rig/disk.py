"""The disk layer under :class:`~puppet.scene.rig.cache.Memo`: built parts kept beside the
scene, in ``.puppet-cache/`` next to the scene file, so a second open is quick.

One entry per part, ``KIND-DIGEST.npz``: the part's arrays, and a JSON tree (the ``meta``
member) saying how to put them together. ``DIGEST`` is a fingerprint of the part's memory
key (which holds the content digests of every file it was built from, see
:func:`~puppet.scene.rig.cache.file_stamp`), the kind, :data:`CODE_VERSION`, the
package version and a stamp of the modules that build parts, so a changed input or
another puppet simply asks for another entry.

Trust nothing read back: an entry whose folder or file is a symbolic link is neither read
nor written; arrays are read with ``allow_pickle=False`` after their headers are checked
(dtype a plain number type, size within the member); every array's dtype and shape must be
what the tree says, floats free of NaN, vertex indices within their mesh and sparse
matrices well formed; the entry must name the digest it is filed under (a swapped file is
refused). Whatever fails is ignored (and rebuilt and written again), never an error. A
read-only or full disk only skips writing. Objects are rebuilt only from the classes in
:data:`CLASSES`; a part holding anything else is not cached on disk at all.

``PUPPET_CACHE=off`` turns it off (tests, CI). The folder is safe to delete.
"""
from __future__ import annotations

import atexit
import contextlib
import dataclasses
import functools
import io
import json
import os
import queue
import stat
import sys
import tempfile
import threading
import time
import zipfile

import numpy as np
import scipy.sparse as sp

from puppet.deform import factor as fz
from puppet.deform.arap import ArapData
from puppet.deform.boundary import ExteriorFrame
from puppet.deform.modes import ModeOps
from puppet.geom.contour import Region
from puppet.geom.merge import GroupMesh
from puppet.geom.triangulate import Mesh
from puppet.scene.rig.build import Group, LayerImage
from puppet.scene.rig.cache import fingerprint
from puppet.scene.rig.exterior import GroupExterior
from puppet.scene.rig.solve import GroupPre

#: Bump when a built part changes for the same inputs (a new field, another algorithm).
CODE_VERSION = 1
#: The cache folder, beside the scene file.
FOLDER = ".puppet-cache"
#: ``PUPPET_CACHE=off`` (or 0, no, false) turns the disk cache off.
ENV = "PUPPET_CACHE"
#: Most bytes kept in one cache folder; the oldest entries go first beyond it.
MAX_BYTES = 1 << 30
#: Kinds of part kept on disk (the costly ones).
KINDS = ("image", "outline", "mesh", "groups", "exterior", "cells", "precompute", "pose",
         "classes")  # the compositor's triangle classes of a drawn layer (puppet.api)

#: The only classes an entry may rebuild (by name); anything else is not cached.
CLASSES = {c.__name__: c for c in (ArapData, ModeOps, Region, GroupMesh, Mesh, Group, LayerImage,
                                   GroupExterior, GroupPre, ExteriorFrame)}
SPARSE = {c.__name__: c for c in (sp.csr_matrix, sp.csc_matrix)}
#: Packages whose code builds the parts (their sources enter every entry's digest).
BUILDERS = ("geom", "deform", "imaging", "scene")
#: Fields a class builds on first access (absent from an entry when never used).
LAZY = {"ArapData": {"C", "K"}}
#: Array attributes that index a mesh's vertices (checked against its ``V``).
VERTEX_INDICES = ("F", "b", "free", "held", "maps", "ei", "ej", "hinges", "couple")


class Unsupported(TypeError):
    """A part holds something the disk layer does not store."""


def enabled() -> bool:
    return os.environ.get(ENV, "on").strip().lower() not in ("off", "0", "no", "false")


@functools.lru_cache(maxsize=1)
def _code_stamp() -> str:
    """The package version and a digest of the name, size and modification time of every
    module that builds parts (a changed source file, even without a new CODE_VERSION,
    asks for new entries)."""
    package = sys.modules["puppet"]  # loaded before any of its modules (importing it here: a circle)
    root = os.path.dirname(os.path.abspath(package.__file__))
    files = []
    for sub in BUILDERS:
        for folder, dirs, names in os.walk(os.path.join(root, sub)):
            dirs.sort()
            for n in sorted(names):
                if n.endswith(".py"):
                    st = os.stat(os.path.join(folder, n))
                    files.append((os.path.relpath(os.path.join(folder, n), root), st.st_size, st.st_mtime_ns))
    return f"{getattr(package, '__version__', '?')}/{fingerprint(files)}"


def beside(scene_file: str | None) -> DiskStore | None:
    """The disk store of an existing scene file, or None (no file, or ``PUPPET_CACHE=off``)."""
    if not enabled() or not scene_file or not os.path.isfile(scene_file):
        return None
    return DiskStore(os.path.join(os.path.dirname(os.path.abspath(scene_file)), FOLDER))


class DiskStore:
    """Entries of one cache folder. ``loads`` / ``saves`` / ``rejects`` count per kind."""

    def __init__(self, folder: str, max_bytes: int | None = None):
        self.folder = folder
        self.max_bytes = int(MAX_BYTES if max_bytes is None else max_bytes)
        self.version = f"{CODE_VERSION}/{_code_stamp()}"
        self.loads: dict[str, int] = {}
        self.saves: dict[str, int] = {}
        self.rejects: dict[str, int] = {}
        self.why: list[str] = []  # why each rejected entry was (for diagnostics)
        self._lock = threading.Lock()

    def holds(self, kind: str) -> bool:
        return kind in KINDS

    def path(self, kind: str, key: str) -> tuple[str, str]:
        digest = fingerprint("puppet-cache", self.version, kind, key)
        return os.path.join(self.folder, f"{kind}-{digest}.npz"), digest

    # -- reading ------------------------------------------------------------------
    def load(self, kind: str, key: str):
        """The part stored under ``key``, or None (missing, stale, unsafe or corrupt)."""
        path, digest = self.path(kind, key)
        if not self._folder_ok(create=False):
            return None
        try:
            raw = _read_regular(path, self.max_bytes)
        except OSError:
            return None
        try:
            value = _unpack(raw, digest)
        except Exception as e:  # a corrupt or hostile entry: rebuilt and written again
            self._count(self.rejects, kind)
            self.why.append(f"{os.path.basename(path)} ({len(raw)} bytes): {type(e).__name__}: {e}"[:300])
            return None
        self._count(self.loads, kind)
        return value

    # -- writing ------------------------------------------------------------------
    def save(self, kind: str, key: str, value) -> bool:
        """Store ``value``; False when it cannot (unsupported content, unsafe or
        read-only folder, full disk): the cache is only skipped."""
        packed = self._packed(kind, key, value)
        return packed is not None and self._store(kind, *packed)

    def save_later(self, kind: str, key: str, value) -> None:
        """:meth:`save` with the writing on the writer thread: a build does not wait for
        the disk (an edit in the app that re-precomputes a big group, the first open of a
        big scene). The part is packed now, as it was built: a solve that adds fields to
        it later (``ArapData``'s cell operators, built on first use) does not change what
        is written."""
        packed = self._packed(kind, key, value)
        if packed is not None:
            # copies: an array changed in place before the writer gets to it would be
            # written changed under the shapes recorded now (suspected in a rare test failure:
            # a mesh entry rewritten after a spoil was rejected at the next open)
            path, arrays = packed
            arrays = {k: np.array(a, copy=True) for k, a in arrays.items()}
            WRITER.put(lambda: self._store(kind, path, arrays))

    def _packed(self, kind: str, key: str, value) -> tuple[str, dict] | None:
        """(entry path, arrays) of ``value``, or None when it holds what is not cached."""
        path, digest = self.path(kind, key)
        try:
            return path, _pack(value, digest)
        except Unsupported:
            return None

    def _store(self, kind: str, path: str, arrays: dict) -> bool:
        if sum(a.nbytes for a in arrays.values()) > self.max_bytes or not self._folder_ok(create=True):
            return False
        try:
            _write(path, arrays)
        except (OSError, ValueError):  # read-only, full, a link in the way
            return False
        self._count(self.saves, kind)
        self._prune()
        return True

    def _folder_ok(self, *, create: bool) -> bool:
        """The folder exists (made when ``create``), is a real folder and no link."""
        try:
            st = os.lstat(self.folder)
        except FileNotFoundError:
            if not create:
                return False
            try:
                os.mkdir(self.folder)
                st = os.lstat(self.folder)
            except OSError:
                return False
        except OSError:
            return False
        return stat.S_ISDIR(st.st_mode)

    def _prune(self) -> None:
        """Drop the oldest entries while the folder holds more than ``max_bytes``, and
        temporary files a killed process left (an hour old)."""
        try:
            entries = []
            old = time.time_ns() - 3600 * 10**9
            with os.scandir(self.folder) as it:
                for e in it:
                    if not e.is_file(follow_symlinks=False):
                        continue
                    st = e.stat(follow_symlinks=False)
                    if e.name.endswith(".npz"):
                        entries.append((st.st_mtime_ns, st.st_size, e.path))
                    elif e.name.endswith(".tmp") and st.st_mtime_ns < old:
                        os.unlink(e.path)
            total = sum(s for _, s, _ in entries)
            for _, size, p in sorted(entries):
                if total <= self.max_bytes:
                    break
                os.unlink(p)
                total -= size
        except OSError:
            pass

    def _count(self, table: dict, kind: str) -> None:
        with self._lock:
            table[kind] = table.get(kind, 0) + 1


class _Writer:
    """One thread that writes entries in the order they come, started when there is work
    and ending when there is none; what is queued is written before the process exits."""

    def __init__(self):
        self._reset()
        atexit.register(self.flush)
        if hasattr(os, "register_at_fork"):  # a forked child has no writer thread: its own queue
            os.register_at_fork(after_in_child=self._reset)

    def _reset(self) -> None:
        self._jobs: queue.Queue = queue.Queue()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def put(self, job) -> None:
        with self._lock:
            self._jobs.put(job)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="puppet-cache-writer", daemon=True)
                self._thread.start()

    def flush(self) -> None:
        """Wait until everything queued is written (or given up)."""
        self._jobs.join()

    def _run(self) -> None:
        while True:
            try:
                job = self._jobs.get(timeout=0.5)
            except queue.Empty:
                with self._lock:
                    if self._jobs.empty():
                        self._thread = None
                        return
                continue
            try:
                job()
            except Exception:  # noqa: BLE001 - a cache write never fails the program
                pass
            finally:
                self._jobs.task_done()


#: the writer of every store of the process
WRITER = _Writer()


def flush() -> None:
    """Wait until every entry queued by :meth:`DiskStore.save_later` is written."""
    WRITER.flush()


def _write(path: str, arrays: dict) -> None:
    """Write an entry atomically: a new temporary file beside it (never an existing file,
    never through a link), renamed into place unless a link stands there. Not registered
    with :mod:`puppet.output`'s leftovers (the command's cleanup must not remove a file the
    writer thread is writing); one a killed process left is pruned an hour later. No
    fsync: a torn entry after a crash fails its checks and is built again."""
    folder, name = os.path.split(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
        if os.path.islink(path):
            raise OSError(f"{path} is a symbolic link")
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _read_regular(path: str, limit: int) -> bytes:
    """The bytes of a regular file that is no symbolic link, at most ``limit`` of them."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
                 | getattr(os, "O_CLOEXEC", 0))
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())
        if not stat.S_ISREG(st.st_mode) or st.st_size > limit:
            raise OSError("not a regular file of a sane size")
        # its size, not the limit: a read of n bytes reserves n at once (1 GiB a read, a
        # MemoryError under `ulimit -v`); bytes written since fstat only fail the checks
        return f.read(st.st_size + 1)


# -- packing: a part as arrays and a JSON tree ---------------------------------------
def _pack(value, digest: str) -> dict[str, np.ndarray]:
    """The arrays of an entry: the part's, and ``meta`` (the JSON tree, as bytes)."""
    arrays: dict[str, np.ndarray] = {}
    tree = _encode(value, arrays, {})
    meta = json.dumps({"digest": digest, "tree": tree}, allow_nan=True).encode()
    arrays["meta"] = np.frombuffer(meta, np.uint8)
    return arrays


def _encode(x, arrays: dict, seen: dict):
    if x is None or isinstance(x, (bool, int, float, str)) and not isinstance(x, np.generic):
        return x
    if isinstance(x, np.ndarray):
        if x.dtype.kind not in "biufc" or x.dtype.hasobject:
            raise Unsupported(f"array of {x.dtype}")
        if id(x) not in seen:  # an array held twice is stored (and rebuilt) once
            seen[id(x)] = f"a{len(seen)}"
            arrays[seen[id(x)]] = x
        return {"nd": seen[id(x)], "dtype": x.dtype.str, "shape": list(x.shape)}
    if isinstance(x, (np.bool_, np.integer, np.floating)):
        return {"np": x.dtype.str, "v": x.item()}
    if type(x).__name__ in SPARSE and isinstance(x, SPARSE[type(x).__name__]):
        return {"sp": type(x).__name__, "shape": list(x.shape),
                **{k: _encode(getattr(x, k), arrays, seen) for k in ("data", "indices", "indptr")}}
    if isinstance(x, tuple) and type(x).__name__ in CLASSES:  # a NamedTuple
        return {"obj": type(x).__name__, "tuple": [_encode(v, arrays, seen) for v in x]}
    if type(x) is list and all(v is None or type(v) in (bool, int, float, str) for v in x):
        return {"json": x}  # a plain list (a mode per vertex) as it is
    if type(x) in (list, tuple):
        return {"list" if type(x) is list else "tuple": [_encode(v, arrays, seen) for v in x]}
    if type(x) is dict and all(isinstance(k, str) for k in x):
        return {"dict": {k: _encode(v, arrays, seen) for k, v in x.items()}}
    if type(x).__module__ == fz.__name__ and getattr(x, "kind", None) in fz.SOLVERS:
        return {"factor": x.kind}
    name = type(x).__name__
    if CLASSES.get(name) is not type(x):
        raise Unsupported(f"a {type(x).__qualname__}")
    fields = dict(vars(x))  # a copy: a field built on first access may come meanwhile
    if dataclasses.is_dataclass(x):  # its fields only (not a cached property)
        fields = {f.name: fields[f.name] for f in dataclasses.fields(x) if f.name in fields}
    return {"obj": name, "fields": {k: _encode(v, arrays, seen) for k, v in fields.items()}}


def _unpack(raw: bytes, digest: str):
    with zipfile.ZipFile(io.BytesIO(raw)) as z:
        for info in z.infolist():
            _check_header(z, info)
    with np.load(io.BytesIO(raw), allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    meta = json.loads(arrays.pop("meta").tobytes().decode())
    if meta.get("digest") != digest:
        raise ValueError("an entry filed under another digest")
    value = _decode(meta["tree"], arrays)
    _sane(value, set())
    return value


def _check_header(z: zipfile.ZipFile, info: zipfile.ZipInfo) -> None:
    """An array member is stored (not compressed: no zip bomb) and holds a plain number
    type and no more elements than its bytes."""
    if info.compress_type != zipfile.ZIP_STORED or info.file_size != info.compress_size:
        raise ValueError(f"member {info.filename!r} is compressed")
    with z.open(info) as f:
        fmt = np.lib.format
        read = fmt.read_array_header_1_0 if fmt.read_magic(f) == (1, 0) else fmt.read_array_header_2_0
        shape, _, dtype = read(f)
    if dtype.hasobject or dtype.kind not in "biufc":
        raise ValueError(f"member {info.filename!r} has dtype {dtype}")
    if int(np.prod(shape, dtype=object)) * dtype.itemsize > info.file_size:
        raise ValueError(f"member {info.filename!r} claims more than it holds")


def _decode(t, arrays: dict):
    if not isinstance(t, dict):
        if t is None or isinstance(t, (bool, int, float, str)):
            return t
        raise ValueError("bad tree")
    if "nd" in t:
        a = arrays[t["nd"]]
        if a.dtype.str != t["dtype"] or list(a.shape) != t["shape"]:
            raise ValueError("an array's dtype or shape differs from its record")
        if a.dtype.kind in "fc" and np.isnan(a).any():
            raise ValueError("NaN in an array")
        return a
    if "np" in t:
        return np.dtype(t["np"]).type(t["v"])
    if "sp" in t:
        m = SPARSE[t["sp"]]((_decode(t["data"], arrays), _decode(t["indices"], arrays),
                             _decode(t["indptr"], arrays)), shape=tuple(int(s) for s in t["shape"]))
        m.check_format(full_check=True)
        return m
    if "factor" in t:
        if t["factor"] not in fz.SOLVERS:
            raise ValueError("unknown factor")
        return _Refactor(t["factor"])
    if "json" in t:
        if not isinstance(t["json"], list) or any(isinstance(v, (dict, list)) for v in t["json"]):
            raise ValueError("bad plain list")
        return t["json"]
    if "list" in t:
        return [_decode(v, arrays) for v in t["list"]]
    if "tuple" in t and "obj" not in t:
        return tuple(_decode(v, arrays) for v in t["tuple"])
    if "dict" in t:
        return {str(k): _decode(v, arrays) for k, v in t["dict"].items()}
    cls = CLASSES[t["obj"]]
    if "tuple" in t:
        return cls(*[_decode(v, arrays) for v in t["tuple"]])
    obj = cls.__new__(cls)
    obj.__dict__.update({str(k): _decode(v, arrays) for k, v in t["fields"].items()})
    if dataclasses.is_dataclass(cls):  # every field there (but those built on first access)
        missing = {f.name for f in dataclasses.fields(cls)} - set(obj.__dict__) - LAZY.get(t["obj"], set())
        if missing:
            raise ValueError(f"{t['obj']} without {sorted(missing)}")
    if isinstance(obj, ArapData) and isinstance(obj.__dict__.get("factor"), _Refactor):
        obj.factor = _Deferred(obj.factor.kind)
        obj.factor.start(obj)  # once in its place: the thread replaces it when done
    return obj


class _Refactor:
    """A factorisation to do again from the matrix it factorised (the factor objects of
    QDLDL, CHOLMOD and SuperLU cannot be rebuilt from arrays)."""

    def __init__(self, kind: str):
        self.kind = kind


class _Deferred:
    """A factor made again on a thread of its own (QDLDL releases the GIL) while the rest
    of the scene loads and its layers are uploaded; its first use waits for it. Once made,
    it takes its own place in the ArapData (``data.factor``), so later solves see the
    factor itself (and may solve the two coordinates on two threads)."""

    def __init__(self, kind: str):
        self.kind = kind
        self._done = threading.Event()
        self._factor = self._error = None

    def start(self, data: ArapData) -> None:
        # not a daemon: the interpreter waits for it at exit (a command that ends before
        # the factor is made, `puppet mesh` from the cache, would else end inside QDLDL's
        # C++ and abort: "terminate called without an active exception")
        threading.Thread(target=self._make, args=(data,), name="puppet-refactor", daemon=False).start()

    def _make(self, data: ArapData) -> None:
        try:
            self._factor = _refactor(data, self.kind)
            data.factor = self._factor
        except BaseException as e:  # raised on first use, where a factorisation would have raised
            self._error = e
        finally:
            self._done.set()

    def __getattr__(self, name):
        self._done.wait()
        if self._error is not None:
            raise self._error
        return getattr(self._factor, name)


def _refactor(data: ArapData, kind: str):
    """The factor of ``L[free][:, free]``, as :func:`~puppet.deform.arap.arap_precompute` makes it."""
    free = np.asarray(data.free)
    A = data.L[free][:, free].tocsr()
    A.sort_indices()
    return fz.factorize(sp.csc_matrix((A.data, A.indices, A.indptr), shape=A.shape), kind)


def _sane(x, seen: set) -> None:
    """Vertices finite and every vertex index within its mesh, all the way down."""
    if id(x) in seen or x is None or isinstance(x, (bool, int, float, str)):
        return
    seen.add(id(x))
    if isinstance(x, (list, tuple)):
        for v in x:
            _sane(v, seen)
        return
    if isinstance(x, dict):
        for v in x.values():
            _sane(v, seen)
        return
    if not hasattr(x, "__dict__") or isinstance(x, (np.ndarray, sp.spmatrix, _Refactor)):
        return
    fields = vars(x)
    V = fields.get("V", getattr(fields.get("mesh"), "V", None))  # a group: its merged mesh's
    if isinstance(V, np.ndarray):
        if V.ndim != 2 or V.shape[1] != 2 or not np.isfinite(V).all():
            raise ValueError("vertices not (n, 2) finite")
        for name in VERTEX_INDICES:
            for a in _arrays(fields.get(name)):
                if a.dtype.kind not in "iu" or (a.size and (a.min() < 0 or a.max() >= len(V))):
                    raise ValueError(f"{name} indexes outside the mesh")
        F = fields.get("F")
        if isinstance(F, np.ndarray) and (F.ndim != 2 or F.shape[1] != 3):
            raise ValueError("triangles not (m, 3)")
    for v in fields.values():
        _sane(v, seen)


def _arrays(x):
    if isinstance(x, np.ndarray):
        return [x]
    if isinstance(x, list):
        return [a for a in x if isinstance(a, np.ndarray)]
    return []
