"""What a batch remembers in OUT_DIR: content hashes of each job's inputs, the manifest
(``manifest.json``: outputs finished, with the hash they were made from) and the report
(``report.json``: every job's result). Both files are written atomically."""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import threading

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
    with open(path, "rb") as f:
        while block := f.read(_CHUNK):
            h.update(block)
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


def _read(path: str) -> dict | None:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
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
