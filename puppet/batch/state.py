"""What a batch remembers in OUT_DIR: content hashes of each job's inputs, the manifest
(``manifest.json``: outputs finished, with the hash they were made from) and the report
(``report.json``: every job's result). Both files are written atomically."""
from __future__ import annotations

import datetime as _dt
import errno
import hashlib
import json
import os
import stat
import threading

from puppet.errors import SceneError
from puppet.output import write_text

MANIFEST = "manifest.json"
REPORT = "report.json"
_CHUNK = 1 << 20

_hashes: dict[tuple, str] = {}  # (path, size, mtime_ns, inode) -> content digest, per process
_lock = threading.Lock()


def file_hash(path: str) -> str:
    """blake2b digest of a file's bytes (kept per process while its size, mtime and inode stay)."""
    st = os.stat(path)
    key = (path, st.st_size, st.st_mtime_ns, st.st_ino)
    with _lock:
        if key in _hashes:
            return _hashes[key]
    h = hashlib.blake2b(digest_size=16)
    # opened without blocking and checked regular before a byte is read: an input that
    # became a FIFO or a link to /dev/zero fails (its job runs again) instead of hanging
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OSError(errno.EINVAL, "not a regular file", path)
        left = st.st_size  # no more than the file held when opened (a growing file: the job re-runs)
        while left > 0 and (block := f.read(min(_CHUNK, left))):
            h.update(block)
            left -= len(block)
        key = (path, st.st_size, st.st_mtime_ns, st.st_ino)
    with _lock:
        if len(_hashes) > 100_000:
            _hashes.clear()
        _hashes[key] = h.hexdigest()
    return _hashes[key]


def inputs_digest(spec: dict, inputs: list[tuple[str, str]]) -> str:
    """One digest of a job: its ``spec`` (pose, size, ...) and the content of every input file.

    Parameters
    ----------
    spec : what besides the files decides the output (:func:`puppet.batch.jobs.spec`).
    inputs : (path, role) of each file read, e.g. ``(".../arm.png", "layers[1].image")``;
        the roles and contents are hashed, not the paths, so a moved folder still matches.

    Raises
    ------
    OSError
        An input that cannot be read.
    """
    parts = [json.dumps(spec, sort_keys=True)]
    parts += [f"{role}={file_hash(path)}" for path, role in inputs]
    return hashlib.blake2b("\n".join(parts).encode(), digest_size=16).hexdigest()


def now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


#: Largest manifest read (bytes); a larger one counts as empty.
MAX_MANIFEST_BYTES = 64 * 1024 * 1024


def _read(path: str) -> dict | None:
    """The manifest's JSON, read bounded and strictly (:func:`puppet.scene.format.reader.read_file`);
    None when missing, not a regular file, too large, too deep or not JSON."""
    from puppet.scene.format.reader import parse_text, read_file  # lazy: numpy (see puppet/batch/__init__.py)

    if not os.path.lexists(path):
        return None
    try:
        data = parse_text(read_file(path, what="manifest", max_bytes=MAX_MANIFEST_BYTES), path)
    except SceneError:
        return None
    return data if isinstance(data, dict) else None


class Manifest:
    """``OUT_DIR/manifest.json``: ``{"puppet_batch_manifest": 1, "outputs": {REL: {"inputs": HASH,
    "finished": ISO}}}``. An unreadable or foreign manifest counts as empty (everything re-renders)."""

    def __init__(self, out_dir: str):
        self.path = os.path.join(out_dir, MANIFEST)
        data = _read(self.path) or {}
        outputs = data.get("outputs") if data.get("puppet_batch_manifest") == 1 else None
        self.outputs: dict[str, dict] = {k: v for k, v in (outputs or {}).items()
                                         if isinstance(v, dict) and isinstance(v.get("inputs"), str)}
        self.dirty = False

    def matches(self, rel: str, digest: str) -> bool:
        entry = self.outputs.get(rel)
        return entry is not None and entry["inputs"] == digest

    def drop(self, rel: str) -> None:
        if self.outputs.pop(rel, None) is not None:
            self.dirty = True

    def add(self, rel: str, digest: str) -> None:
        self.outputs[rel] = {"inputs": digest, "finished": now()}
        self.dirty = True

    def save(self) -> None:
        text = json.dumps({"puppet_batch_manifest": 1, "outputs": dict(sorted(self.outputs.items()))}, indent=1)
        write_text(self.path, text + "\n")
        self.dirty = False


def write_report(out_dir: str, report: dict) -> str:
    """Write ``OUT_DIR/report.json`` atomically; returns its path."""
    path = os.path.join(out_dir, REPORT)
    write_text(path, json.dumps(report, indent=1) + "\n")
    return path
