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
import re
import stat

import numpy as np

from puppet.errors import SceneError
from puppet.scene.schema import join, short

#: Largest scene file read (bytes).
MAX_SCENE_BYTES = 16 * 1024 * 1024
#: Deepest nesting of lists and objects (the format itself needs 6).
MAX_DEPTH = 32
#: Largest integer magnitude: every integer up to 2^53 is exact as a float.
MAX_INT = 2 ** 53

_STRING_B = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_TOKEN = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[{}\[\],:]|[^\s{}\[\],:"]+|"', re.DOTALL)
_NUMBER = re.compile(r"-?(?:0|[1-9]\d*)(\.\d+)?([eE][+-]?\d+)?")


class _Refused(ValueError):
    """Raised from inside ``json.loads`` hooks; the value's path is found afterwards."""


def read_text(path: str) -> str:
    """The text of a scene file, refusing anything that is not a readable regular
    UTF-8 file of at most MAX_SCENE_BYTES (a leading byte-order mark is allowed)."""
    def fail(msg: str) -> SceneError:
        return SceneError(msg, file=path)

    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise fail("no such scene file") from None
    except OSError as e:
        raise fail(f"cannot be read ({e.strerror})") from None
    _check_stat(st, fail)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise fail(f"cannot be read ({e.strerror})") from None
    try:
        _check_stat(os.fstat(fd), fail)  # the file may have been swapped since stat
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read(MAX_SCENE_BYTES + 1)
    except OSError as e:
        raise fail(f"cannot be read ({e.strerror})") from None
    finally:
        os.close(fd)
    if len(data) > MAX_SCENE_BYTES:
        raise fail(f"too large for a scene file (more than {MAX_SCENE_BYTES // (1024 * 1024)} MiB)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise fail(f"not a text (UTF-8) file (byte 0x{data[e.start]:02x} at offset {e.start})") from None


def _check_stat(st: os.stat_result, fail) -> None:
    if stat.S_ISDIR(st.st_mode):
        raise fail("is a folder, not a scene file")
    if not stat.S_ISREG(st.st_mode):
        raise fail("is not a regular file (a FIFO, device or socket cannot be a scene)")
    if st.st_size > MAX_SCENE_BYTES:
        raise fail(f"too large for a scene file ({st.st_size} bytes; at most "
                   f"{MAX_SCENE_BYTES // (1024 * 1024)} MiB)")


def parse_text(text: str, file: str):
    """Parse scene JSON; every problem becomes one SceneError with file and JSON path."""
    if max_depth(text) > MAX_DEPTH:
        raise _located(text, file, f"nested deeper than {MAX_DEPTH} levels of lists and objects")
    try:
        return json.loads(text, object_pairs_hook=_pairs, parse_constant=_constant,
                          parse_int=_int, parse_float=_float)
    except _Refused as e:
        raise _located(text, file, f"{e} is not allowed in a scene") from None
    except json.JSONDecodeError as e:
        where = locate(text, stop=e.pos)[0]
        raise SceneError(f"invalid JSON at line {e.lineno} column {e.colno}: {e.msg}",
                         file=file, path=where or None) from None
    except (RecursionError, ValueError) as e:  # not expected after the checks above
        raise SceneError(f"invalid JSON ({e})", file=file) from None


def max_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` outside strings (vectorised, no recursion)."""
    data = text.encode("utf-8")
    if data.count(b"[") + data.count(b"{") <= MAX_DEPTH:
        return 0
    b = np.frombuffer(_STRING_B.sub(b'""', data), np.uint8)
    deepest, depth, chunk = 0, 0, 1 << 20
    for s in range(0, len(b), chunk):
        part = b[s:s + chunk]
        step = ((part == ord("[")) | (part == ord("{"))).astype(np.int32)
        step -= ((part == ord("]")) | (part == ord("}"))).astype(np.int32)
        d = np.cumsum(step) + depth
        if len(d):
            deepest = max(deepest, int(d.max()))
            depth = int(d[-1])
    return deepest


def _pairs(pairs: list) -> dict:
    d = dict(pairs)
    if len(d) != len(pairs):
        raise _Refused("duplicate key")
    return d


def _constant(name: str):
    raise _Refused(name)


def _int(s: str) -> int:
    if len(s) - s.startswith("-") > 16 or abs(int(s)) > MAX_INT:
        raise _Refused(s)
    return int(s)


def _float(s: str) -> float:
    v = float(s)
    if not math.isfinite(v):
        raise _Refused(s)
    return v


def _located(text: str, file: str, fallback: str) -> SceneError:
    where, problem = locate(text)
    if problem is None:
        where = ""
    return SceneError(problem or fallback, file=file, path=where or None)


def _number_problem(t: str) -> str | None:
    if t in ("NaN", "Infinity", "-Infinity"):
        return f"{t} is not allowed in a scene (numbers must be finite)"
    m = _NUMBER.fullmatch(t)
    if m is None:
        return None  # true, false, null, or junk json reports itself
    short = t if len(t) <= 24 else t[:20] + "..."
    if m.group(1) is None and m.group(2) is None:
        if len(t) - t.startswith("-") > 16 or abs(int(t)) > MAX_INT:
            return f"integer {short} is too large (at most 2^53 = {MAX_INT} in magnitude)"
    elif not math.isfinite(float(t)):
        return f"number {short} is too large for a float"
    return None


def locate(text: str, stop: int | None = None) -> tuple[str, str | None]:
    """Walk the JSON tokens without recursion, tracking the JSON path.

    Returns ``(path, problem)`` for the first value that nests deeper than MAX_DEPTH,
    repeats a key or is a number a scene cannot hold; with ``stop`` (a character
    offset), the path of the value being read there and no problem. Tolerates
    invalid JSON (it only needs to find where things are).
    """
    # each frame: [is_object, key or index, keys seen (objects), expecting a key]
    stack: list[list] = []

    def path() -> str:
        out = ""
        for is_obj, k, _, _ in stack:
            if is_obj and k is None:
                break
            out = join(out, k)
        return out

    for m in _TOKEN.finditer(text):
        if stop is not None and m.start() >= stop:
            if stack and stack[-1][0] and stack[-1][3]:
                stack[-1][1] = None  # between keys: the object itself is the place
            break
        t = m.group()
        c = t[0]
        top = stack[-1] if stack else None
        if c in "[{":
            if len(stack) >= MAX_DEPTH:
                return path(), f"nested deeper than {MAX_DEPTH} levels of lists and objects"
            stack.append([c == "{", None if c == "{" else 0, set() if c == "{" else None, c == "{"])
        elif c in "]}":
            if stack:
                stack.pop()
        elif c == ",":
            if top is not None:
                if top[0]:
                    top[3] = True
                else:
                    top[1] += 1
        elif c == ":":
            if top is not None and top[0]:
                top[3] = False
        elif c == '"':
            if top is not None and top[0] and top[3] and len(t) > 1:
                try:
                    key = json.loads(t)
                except ValueError:
                    key = t[1:-1]
                top[1] = key
                if key in top[2]:
                    return path(), f"duplicate key {short(key)} (a key may appear only once in an object)"
                top[2].add(key)
        elif stop is None:
            problem = _number_problem(t)
            if problem:
                return path(), problem
    return path(), None
