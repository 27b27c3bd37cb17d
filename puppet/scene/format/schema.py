"""Small validators that know the JSON path of the value they check.

Each ``expect_*`` returns the converted value or raises SceneError naming the scene
file, the JSON path (``layers[2].mask.polygon``) and what is wrong.
"""
from __future__ import annotations

import json
import math
import re
from typing import Any

from puppet.errors import SceneError

#: Every number in a scene lies within +-MAX_COORD unless its key has a tighter range:
#: coordinates, offsets, pose targets, rectangles, orders (canvas pixels or plain numbers).
MAX_COORD = 1e6


class Ctx:
    """The scene file being read, to build errors."""

    def __init__(self, file: str):
        self.file = file

    def fail(self, path: str, message: str) -> SceneError:
        return SceneError(message, file=self.file, path=path)


_PLAIN_KEY = re.compile(r"[^\s.\[\]\"'\\]{1,60}")


def join(path: str, key: str | int) -> str:
    """``path.key`` or ``path[i]``; a key with spaces, dots, brackets, quotes or control
    characters is written ``path["k e y"]`` (JSON-escaped, so always one line), and a key
    longer than 60 characters is cut short."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    if _PLAIN_KEY.fullmatch(key):
        return f"{path}.{key}" if path else key
    k = json.dumps(key if len(key) <= 60 else key[:57] + "...")
    return f"{path}[{k}]"


def short(v: Any, n: int = 60) -> str:
    """``repr(v)`` cut to ``n`` characters, for messages that quote what the user wrote."""
    r = repr(v)
    return r if len(r) <= n else r[:n - 3] + "..."


def expect_object(c: Ctx, v: Any, path: str, *, required=(), optional=()) -> dict:
    if not isinstance(v, dict):
        raise c.fail(path or "(top level)", f"expected an object, got {_kind(v)}")
    allowed = set(required) | set(optional)
    for k in v:
        if k not in allowed:
            hint = ", ".join(sorted(allowed))
            raise c.fail(join(path, k), f"unknown key {short(k)} (allowed here: {hint})")
    for k in required:
        if k not in v:
            raise c.fail(join(path, k), "required key is missing")
    return v


def expect_list(c: Ctx, v: Any, path: str, *, min_len: int = 0, length: int | None = None,
                max_len: int | None = None) -> list:
    if not isinstance(v, list):
        raise c.fail(path, f"expected a list, got {_kind(v)}")
    if max_len is not None and len(v) > max_len:
        raise c.fail(path, f"expected at most {max_len} items, got {len(v)}")
    if length is not None and len(v) != length:
        raise c.fail(path, f"expected a list of {length} items, got {len(v)}")
    if len(v) < min_len:
        raise c.fail(path, f"expected at least {min_len} item{'s' if min_len != 1 else ''}, got {len(v)}")
    return v


def expect_number(c: Ctx, v: Any, path: str, *, lo=-MAX_COORD, hi=MAX_COORD, lo_open=False,
                  integer=False) -> float:
    """A finite number in [lo, hi] (``(lo, hi]`` with ``lo_open``); by default within
    +-MAX_COORD, so no solver ever sees a huge value."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise c.fail(path, f"expected a number, got {_kind(v)}")
    if not math.isfinite(v):
        raise c.fail(path, f"expected a finite number, got {v}")
    if integer and float(v) != int(v):
        raise c.fail(path, f"expected a whole number, got {v}")
    if v < lo or (lo_open and v == lo):
        raise c.fail(path, f"must be {'>' if lo_open else '>='} {lo:g}, got {v:g}")
    if v > hi:
        raise c.fail(path, f"must be <= {hi:g}, got {v:g}")
    return int(v) if integer else float(v)


def expect_point(c: Ctx, v: Any, path: str) -> tuple[float, float]:
    expect_list(c, v, path, length=2)
    return (expect_number(c, v[0], join(path, 0)), expect_number(c, v[1], join(path, 1)))


def expect_string(c: Ctx, v: Any, path: str, *, choices=None, nonempty=True) -> str:
    if not isinstance(v, str):
        raise c.fail(path, f"expected a string, got {_kind(v)}")
    if nonempty and not v.strip():
        raise c.fail(path, "must not be empty")
    if choices is not None and v not in choices:
        raise c.fail(path, f"{short(v)} is not one of: {', '.join(choices)}")
    return v


def expect_bool(c: Ctx, v: Any, path: str) -> bool:
    if not isinstance(v, bool):
        raise c.fail(path, f"expected true or false, got {_kind(v)}")
    return v


def _kind(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return f"{str(v).lower()}"
    if isinstance(v, (int, float)):
        return f"the number {v}"
    if isinstance(v, str):
        return f"the string {short(v)}"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "an object"
    return type(v).__name__
