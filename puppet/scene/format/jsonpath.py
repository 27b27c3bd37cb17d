"""Where things are in a JSON text, found with numpy: no recursion and no Python loop per
token, so even a scene file at the size limit is searched in about a second.

:class:`Structure` finds the brackets, commas and colons outside strings and the depth
after each; from those, :meth:`Structure.path_at` gives the JSON path of any byte offset
(``layers[2].mask.polygon[7]``), and :meth:`Structure.first_problem` the first value a
scene cannot hold (nesting too deep, a repeated key, ``NaN``/``Infinity``, a number too
large) with its path.
"""
from __future__ import annotations

import json
import math
import re

import numpy as np

from puppet.scene.format.schema import join, short

_LUT = np.zeros(256, bool)
_LUT[[ord(c) for c in "[]{},:"]] = True
_CONSTANT = re.compile(rb"-?Infinity|NaN")
_BIG_HINT = re.compile(rb"\d{16}|[eE][+-]?\d{3}")  # a long number or a 3-digit exponent
_NUMBER_CHARS = frozenset(b"0123456789+-.eE")
_NUMBER = re.compile(r"-?(?:0|[1-9]\d*)(\.\d+)?([eE][+-]?\d+)?")


def _real_quotes(b: np.ndarray) -> np.ndarray:
    """Offsets of the quotes not escaped by an odd run of backslashes, (k,) int64."""
    q = np.flatnonzero(b == ord('"'))
    bs = (b == ord("\\")).view(np.int8)
    if not len(q) or not bs.any():
        return q
    d = np.diff(np.concatenate([[0], bs, [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)  # runs [start, end)
    i = np.minimum(np.searchsorted(ends, q), len(ends) - 1)
    escaped = (ends[i] == q) & ((ends[i] - starts[i]) % 2 == 1)
    return q[~escaped]


class _ByLevel:
    """Structural indices grouped by depth: the last one before an index, or a count."""

    def __init__(self, idx: np.ndarray, level: np.ndarray, n: int):
        self.n = n + 1
        self.key = np.sort(level.astype(np.int64) * self.n + idx)

    def last_before(self, level: int, end: int) -> int | None:
        j = int(np.searchsorted(self.key, level * self.n + end)) - 1
        return int(self.key[j] - level * self.n) if j >= 0 and self.key[j] // self.n == level else None

    def last_before_many(self, level: np.ndarray, end: np.ndarray) -> np.ndarray:
        """:meth:`last_before` for many (level, end) at once; -1 where there is none."""
        want = level.astype(np.int64) * self.n + end
        j = np.searchsorted(self.key, want) - 1
        got = self.key[np.maximum(j, 0)] if len(self.key) else np.zeros(len(want), np.int64)
        ok = (j >= 0) & (got // self.n == level)
        return np.where(ok, got - level.astype(np.int64) * self.n, -1)

    def count(self, level: int, start: int, end: int) -> int:
        base = level * self.n
        return int(np.searchsorted(self.key, base + end) - np.searchsorted(self.key, base + start + 1))


class Structure:
    """The structural characters of a JSON text (as UTF-8 bytes) outside strings.

    Attributes
    ----------
    pos : (s,) int64 byte offsets of ``[]{},:`` outside strings. ch : (s,) uint8 those bytes.
    depth : (s,) int32 nesting depth after each (the top-level value's bracket makes 1).
    """

    def __init__(self, data: bytes):
        self.data = data
        b = np.frombuffer(data, np.uint8)
        self.quotes = _real_quotes(b)
        cand = np.flatnonzero(_LUT[b])
        self.pos = cand[np.searchsorted(self.quotes, cand) % 2 == 0]
        self.ch = b[self.pos]
        step = np.isin(self.ch, (ord("["), ord("{"))).astype(np.int32)
        step -= np.isin(self.ch, (ord("]"), ord("}"))).astype(np.int32)
        self.depth = np.cumsum(step, dtype=np.int32)
        n = len(self.pos)
        groups = {}
        for name, mask in (("open", step == 1), ("comma", self.ch == ord(",")), ("colon", self.ch == ord(":"))):
            idx = np.flatnonzero(mask)
            groups[name] = _ByLevel(idx, self.depth[idx], n)
        self._open, self._comma, self._colon = groups["open"], groups["comma"], groups["colon"]

    def max_depth(self) -> int:
        return int(self.depth.max()) if len(self.depth) else 0

    def outside_strings(self, offset: int) -> bool:
        return int(np.searchsorted(self.quotes, offset, side="right")) % 2 == 0

    def _key_before(self, colon: int) -> str:
        """The key string that ends just before structural index ``colon``."""
        j = int(np.searchsorted(self.quotes, self.pos[colon])) - 1
        if j < 1:
            return ""
        raw = self.data[self.quotes[j - 1]:self.quotes[j] + 1].decode("utf-8", "replace")
        try:
            return json.loads(raw)
        except ValueError:
            return raw[1:-1]

    def path_at(self, offset: int) -> str:
        """JSON path of the value being read at byte ``offset`` (the containers open
        there, with the current list index or object key; between an object's members,
        the object itself)."""
        before = int(np.searchsorted(self.pos, offset))  # structural chars before offset
        if before == 0:
            return ""
        d = int(self.depth[before - 1])
        opens = [self._open.last_before(k, before) for k in range(1, d + 1)]
        path = ""
        for k, a in enumerate(opens, 1):
            if a is None:
                break
            end = opens[k] if k < d and opens[k] is not None else before
            if self.ch[a] == ord("["):
                path = join(path, self._comma.count(k, a, end))
                continue
            c = self._colon.last_before(k, end)
            if c is None or c < a:
                break
            m = self._comma.last_before(k, end)
            if m is not None and m > c:  # between members: the object is the place
                break
            path = join(path, self._key_before(c))
        return path

    def first_problem(self, max_depth: int, max_int: int, kinds=("depth", "duplicate", "constant", "number")):
        """``(path, message)`` of the first value, in document order, that nests deeper
        than ``max_depth``, repeats a key of its object, is ``NaN``/``Infinity``, or is an
        integer beyond ``max_int`` or a float overflow; None when there is none."""
        found = []
        if "depth" in kinds:
            deep = np.flatnonzero(self.depth > max_depth)
            if len(deep):
                at = int(self.pos[deep[0]])
                found.append((at, self.path_at(at), f"nested deeper than {max_depth} levels of lists and objects"))
        if "constant" in kinds:
            for m in _CONSTANT.finditer(self.data):
                if self.outside_strings(m.start()):
                    t = m.group().decode()
                    found.append((m.start(), self.path_at(m.start()),
                                  f"{t} is not allowed in a scene (numbers must be finite)"))
                    break
        if "number" in kinds:
            end = 0
            for m in _BIG_HINT.finditer(self.data):
                if m.start() < end:
                    continue
                start, end = m.start(), m.end()
                while start > 0 and self.data[start - 1] in _NUMBER_CHARS:
                    start -= 1
                while end < len(self.data) and self.data[end] in _NUMBER_CHARS:
                    end += 1
                problem = number_problem(self.data[start:end].decode(), max_int)
                if problem and self.outside_strings(start):
                    found.append((start, self.path_at(start), problem))
                    break
        if "duplicate" in kinds:
            dup = self._first_duplicate()
            if dup is not None:
                found.append(dup)
        return min(found)[1:] if found else None

    def _first_duplicate(self):
        colons = np.flatnonzero(self.ch == ord(":"))
        if not len(colons):
            return None
        level = self.depth[colons]
        # the object each key belongs to: the last '{' at the key's level before it
        container = self._open.last_before_many(level, colons).tolist()
        q = np.searchsorted(self.quotes, self.pos[colons])
        ends = self.quotes[np.maximum(q - 1, 0)].tolist() if len(self.quotes) else [0] * len(colons)
        starts = self.quotes[np.maximum(q - 2, 0)].tolist() if len(self.quotes) else [0] * len(colons)
        for decode in (False, True):  # raw bytes first; then escapes ("a" == "\u0061")
            seen = set()
            for i, (obj, s, e) in enumerate(zip(container, starts, ends)):
                raw = self.data[s:e + 1]
                key = (obj, self._key_before(colons[i]) if decode else raw)
                if key in seen:
                    at = int(s)
                    return at, join(self.path_at(at), self._key_before(colons[i])), \
                        f"duplicate key {short(self._key_before(colons[i]))} (a key may appear only once in an object)"
                seen.add(key)
        return None


def number_problem(t: str, max_int: int) -> str | None:
    """Why number token ``t`` cannot be in a scene, or None."""
    m = _NUMBER.fullmatch(t)
    if m is None:
        return None
    s = t if len(t) <= 24 else t[:20] + "..."
    if m.group(1) is None and m.group(2) is None:
        if len(t) - t.startswith("-") > 16 or abs(int(t)) > max_int:
            return f"integer {s} is too large (at most 2^53 = {max_int} in magnitude)"
    elif not math.isfinite(float(t)):
        return f"number {s} is too large for a float"
    return None
