"""The vectorised JSON locator against a plain token-by-token reference walker."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from puppet.scene.format.jsonpath import Structure
from puppet.scene.format.schema import join

_TOKEN = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[{}\[\],:]|[^\s{}\[\],:"]+', re.DOTALL)


def reference_path(text: str, stop: int) -> str:
    """Walk tokens one at a time (slow, obviously right) up to character ``stop``."""
    stack: list[list] = []  # [is_object, key or index, expecting a key]
    for m in _TOKEN.finditer(text):
        if m.start() >= stop:
            break
        t = m.group()
        top = stack[-1] if stack else None
        if t in ("[", "{"):
            stack.append([t == "{", None if t == "{" else 0, t == "{"])
        elif t in ("]", "}"):
            stack.pop()
        elif t == ",":
            if top[0]:
                top[2] = True
            else:
                top[1] += 1
        elif t == ":":
            top[2] = False
        elif t.startswith('"') and top is not None and top[0] and top[2]:
            top[1] = json.loads(t)
    if stack and stack[-1][0] and stack[-1][2]:
        stack[-1][1] = None
    path = ""
    for is_obj, k, _ in stack:
        if is_obj and k is None:
            break
        path = join(path, k)
    return path


def _random_doc(rng, depth=0):
    r = rng.random()
    if depth > 4 or r < 0.3:
        return rng.choice([1, -2.5, "s", 'q"[{,:}]\\', None, True, "\\\\", "\u00e9\u4e2d"])
    if r < 0.65:
        return [_random_doc(rng, depth + 1) for _ in range(int(rng.integers(0, 4)))]
    keys = ["a", "b c", "x.y", "[k]", 'q"', "\u00e9", "n\nl"]
    return {str(rng.choice(keys)) + str(i): _random_doc(rng, depth + 1) for i in range(int(rng.integers(0, 4)))}


def test_path_at_matches_reference_everywhere():
    rng = np.random.default_rng(7)
    for _ in range(60):
        text = json.dumps(_random_doc(rng), indent=int(rng.integers(0, 2)) or None, ensure_ascii=bool(rng.random() < 0.5))
        s = Structure(text.encode("utf-8"))
        for stop in range(len(text) + 1):
            want = reference_path(text, stop)
            got = s.path_at(len(text[:stop].encode("utf-8")))
            assert got == want, (text, stop, got, want)


def test_hand_checked_paths():
    text = '{"layers": [{"name": "a", "mask": {"polygon": [[0, 0], [5, "x]"], [9, 9]]}}], "pins": []}'
    s = Structure(text.encode())
    assert s.path_at(text.index("9, 9")) == "layers[0].mask.polygon[2][0]"
    assert s.path_at(text.index('"x]"')) == "layers[0].mask.polygon[1][1]"
    assert s.path_at(text.index('"mask"')) == "layers[0]"
    assert s.path_at(text.index("[]")) == "pins"
    assert s.max_depth() == 6


@pytest.mark.parametrize("text,path,words", [
    ('{"a": {"b": 1, "c": 2, "b": 3}}', "a.b", "duplicate key 'b'"),
    ('{"a": {"b": 1}, "c": {"b": 2}}', None, None),                     # same key, different objects
    ('{"a": [{"k": 1}, {"k": 2, "k": 3}]}', "a[1].k", "duplicate key 'k'"),
    ('{"k\\u0041": 1, "kA": 2}', "kA", "duplicate key 'kA'"),           # equal once unescaped
    ('{"s": "NaN [ {", "v": [1, NaN]}', "v[1]", "NaN is not allowed"),
    ('{"v": [1, -Infinity]}', "v[1]", "-Infinity is not allowed"),
    ('{"v": {"w": 12345678901234567890}}', "v.w", "integer 12345678901234567890 is too large"),
    ('{"v": [0.5, 1e400]}', "v[1]", "number 1e400 is too large for a float"),
    ('{"s": "1e400", "v": 1e300}', None, None),                          # in a string; finite
    ('{"a": ' + "[" * 40 + "]" * 40 + "}", "a" + "[0]" * 31, "nested deeper than 32"),
])
def test_first_problem(text, path, words):
    found = Structure(text.encode()).first_problem(32, 2 ** 53)
    if path is None:
        assert found is None
    else:
        assert found[0] == path and words in found[1], found


def test_escaped_quotes_and_backslashes():
    text = json.dumps({"a\\": ['\\"[', "\\\\"], "b": {"c\"": [1, [2]]}})
    s = Structure(text.encode())
    assert s.max_depth() == 4
    assert s.path_at(text.index("[2]") + 1) == 'b["c\\""][1][0]'
