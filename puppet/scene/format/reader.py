"""Read a scene file's JSON strictly: what JSON allows but a scene cannot mean is refused.

Refused, each with one :class:`SceneError` naming the file (and the JSON path where
there is one): a path that is not a regular file (folder, FIFO, device, socket), a file
larger than :data:`MAX_SCENE_BYTES`, text that is not UTF-8, invalid JSON, nesting
deeper than :data:`MAX_DEPTH`, a key repeated in one object, ``NaN``/``Infinity``,
integers beyond :data:`MAX_INT` (not exact as a float) and numbers that overflow a float.

Nothing here recurses, so no input can raise ``RecursionError``; and the file is opened
without blocking and checked with ``fstat`` before it is read, so a FIFO cannot hang.
"""
from __future__ import annotations

import json
import math
import os
import stat

from puppet.errors import SceneError
from puppet.scene.format.jsonpath import Structure

#: Largest scene file read (bytes).
MAX_SCENE_BYTES = 8 * 1024 * 1024
#: Deepest nesting of lists and objects (the format itself needs 6).
MAX_DEPTH = 32
#: Largest integer magnitude: every integer up to 2^53 is exact as a float.
MAX_INT = 2 ** 53


class _Refused(ValueError):
    """Raised from inside ``json.loads`` hooks; the value's path is found afterwards."""

    def __init__(self, what: str, kinds: tuple[str, ...]):
        super().__init__(what)
        self.kinds = kinds


def read_text(path: str) -> str:
    """The text of a scene file, refusing anything that is not a readable regular
    UTF-8 file of at most MAX_SCENE_BYTES (a leading byte-order mark is allowed); a
    picture given where a scene belongs is named as one, with the command that makes a
    scene of it."""
    kind = picture_kind(path)
    if kind is not None:
        raise SceneError(f"is {kind}, not a scene file: make a scene of it with "
                         f"`puppet init {path} -o scene.json`", file=path)
    return read_file(path, what="scene file", max_bytes=MAX_SCENE_BYTES)


#: Leading bytes of the pictures and layered art ``puppet init`` reads: (offset, bytes, name).
_SIGNATURES = ((0, b"\x89PNG\r\n\x1a\n", "a PNG image"), (0, b"\xff\xd8\xff", "a JPEG image"),
               (0, b"GIF87a", "a GIF image"), (0, b"GIF89a", "a GIF image"), (8, b"WEBP", "a WebP image"),
               (0, b"BM", "a BMP image"), (0, b"II*\x00", "a TIFF image"), (0, b"MM\x00*", "a TIFF image"),
               (0, b"8BPS", "a Photoshop document"))
#: Zip containers recognised by their name: OpenRaster and Krita documents.
_ZIPPED = {".ora": "an OpenRaster document", ".kra": "a Krita document"}


def picture_kind(path: str) -> str | None:
    """What picture format ``path`` holds ("a PNG image", ...), read from its first bytes
    (a regular file only, never blocking), or None: not one, or not readable."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except (OSError, ValueError):
        return None
    try:
        head = os.read(fd, 16) if stat.S_ISREG(os.fstat(fd).st_mode) else b""
    except OSError:
        return None
    finally:
        os.close(fd)
    for at, sig, name in _SIGNATURES:
        if head[at:at + len(sig)] == sig:
            return name
    if head.startswith(b"PK\x03\x04"):
        return _ZIPPED.get(os.path.splitext(path)[1].lower())
    return None


def parse_text(text: str, file: str):
    """Parse scene JSON; every problem becomes one SceneError with file and JSON path."""
    data = text.encode("utf-8")
    if data.count(b"[") + data.count(b"{") > MAX_DEPTH:
        structure = Structure(data)
        if structure.max_depth() > MAX_DEPTH:
            raise _located(structure, ("depth",), file, f"nested deeper than {MAX_DEPTH} levels")
        del structure  # rebuilt on error only: keep the peak memory of parsing low
    try:
        return json.loads(text, object_pairs_hook=_pairs, parse_constant=_constant,
                          parse_int=_int, parse_float=_float)
    except _Refused as e:
        raise _located(Structure(data), e.kinds, file, f"{e} is not allowed in a scene") from None
    except json.JSONDecodeError as e:
        where = Structure(data).path_at(len(text[:e.pos].encode("utf-8")))
        raise SceneError(f"invalid JSON at line {e.lineno} column {e.colno}: {e.msg}",
                         file=file, path=where or None) from None
    except (RecursionError, ValueError) as e:  # not expected after the checks above
        raise SceneError(f"invalid JSON ({e})", file=file) from None


def _pairs(pairs: list) -> dict:
    d = dict(pairs)
    if len(d) != len(pairs):
        raise _Refused("a duplicate key", ("duplicate",))
    return d


def _constant(name: str):
    raise _Refused(name, ("constant",))


def _int(s: str) -> int:
    if len(s) - s.startswith("-") > 16 or abs(int(s)) > MAX_INT:
        raise _Refused(s, ("number",))
    return int(s)


def _float(s: str) -> float:
    v = float(s)
    if not math.isfinite(v):
        raise _Refused(s, ("number",))
    return v


def _located(structure: Structure, kinds, file: str, fallback: str) -> SceneError:
    found = structure.first_problem(MAX_DEPTH, MAX_INT, kinds)
    where, problem = found if found else ("", fallback)
    return SceneError(problem, file=file, path=where or None)


def read_file(path: str, *, what: str, max_bytes: int) -> str:
    """The UTF-8 text of a scene file (:func:`read_text`) or of another JSON file a command
    reads (a job list, a manifest, an anchors file): a regular file only (opened without blocking
    and checked with ``fstat``, so a FIFO or a link to ``/dev/zero`` cannot hang or fill
    memory) and at most ``max_bytes``. ``what`` names the file in messages ("job list").

    Raises
    ------
    SceneError
        Naming ``path``: missing, not a regular file, too large, unreadable or not UTF-8.
    """
    def fail(msg: str) -> SceneError:
        return SceneError(msg, file=path)

    def check(st: os.stat_result) -> None:
        if stat.S_ISDIR(st.st_mode):
            raise fail(f"is a folder, not a {what}")
        if not stat.S_ISREG(st.st_mode):
            raise fail(f"is not a regular file (a FIFO, device or socket cannot be a {what})")
        if st.st_size > max_bytes:
            raise fail(f"too large for a {what} ({st.st_size} bytes; at most {max_bytes // (1024 * 1024)} MiB)")

    try:
        check(os.stat(path))
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise fail(f"no such {what}") from None
    except (OSError, ValueError) as e:  # ValueError: a NUL byte in the path
        raise fail(f"cannot be read ({getattr(e, 'strerror', None) or e})") from None
    try:
        check(os.fstat(fd))  # the file may have been swapped since stat
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read(max_bytes + 1)
    except OSError as e:
        raise fail(f"cannot be read ({e.strerror})") from None
    finally:
        os.close(fd)
    if len(data) > max_bytes:
        raise fail(f"too large for a {what} (more than {max_bytes // (1024 * 1024)} MiB)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise fail(f"not a text (UTF-8) file (byte 0x{data[e.start]:02x} at offset {e.start})") from None
