"""Property tests of the scene loader (issue 8): bundled scenes mutated at random
(keys deleted, values of other types, huge / negative / NaN numbers, keys duplicated in
the raw text, deep nesting, odd number tokens, bad bytes, truncation) either load or
raise :class:`puppet.SceneError` with a one-line message naming the file, never anything
else.

Profiles: ``PUPPET_HYPOTHESIS=ci`` (default: derandomized, so CI is deterministic, and
small) or ``sweep`` (2000 random examples); with ``PUPPET_SWEEP_REPORT=file.json`` the
outcome counts are written there.
"""
from __future__ import annotations

import copy
import glob
import json
import os
import re
import shutil
import tempfile
from collections import Counter

import pytest
pytest.importorskip("hypothesis", reason="hypothesis (a test extra: pip install -e '.[test]') is not installed")
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis import given

from puppet.errors import SceneError
from puppet.scene.format.load import load_scene_data
from tests.conftest import ROOT, SCENES

settings.register_profile("puppet-ci", max_examples=60, derandomize=True, deadline=None, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.register_profile("puppet-sweep", max_examples=2000, derandomize=False, deadline=None, database=None,
                          suppress_health_check=list(HealthCheck))
MODE = os.environ.get("PUPPET_HYPOTHESIS", "ci")
PROFILE = settings.get_profile("puppet-sweep" if MODE == "sweep" else "puppet-ci")
BUILD_PROFILE = settings(PROFILE, max_examples=200 if MODE == "sweep" else 8)

ACCEPTANCE = os.path.join(ROOT, "..", "shared", "acceptance")  # beside the project, when present
SEEDS = sorted(glob.glob(os.path.join(SCENES, "*.json")) + glob.glob(os.path.join(ACCEPTANCE, "*.json")))
PARSED = {p: json.load(open(p)) for p in SEEDS}
OUTCOMES: Counter = Counter()
WORK = tempfile.mkdtemp(prefix="puppet-props-")
DEEP = "\u0001DEEP"

WEIRD_NUMBERS = [1e300, -1e300, 1e6 + 1, -1e6 - 1, 1e6, -1e6, 0, -0.0, 1e-300, 2 ** 53 + 1, -(2 ** 64),
                 10 ** 400, float("nan"), float("inf"), float("-inf"), -1, 0.5, 16385, 3.5]
WEIRD_TOKENS = ["1e400", "-1e400", "NaN", "Infinity", "-Infinity", "-", "01", "1.", ".5", "0x10", "1e",
                "9" * 30, "1" * 5000, "true", "null", '"x"', "[]", "{}"]

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2 ** 70, 2 ** 70) | st.floats() | st.text(max_size=6)
    | st.sampled_from(WEIRD_NUMBERS),
    lambda ch: st.lists(ch, max_size=3) | st.dictionaries(st.text(max_size=5), ch, max_size=3),
    max_leaves=6)


def _slots(doc) -> list[tuple]:
    """Every (container, key) in the document, iteratively."""
    out, todo = [], [doc]
    while todo:
        c = todo.pop()
        keys = list(c) if isinstance(c, dict) else range(len(c)) if isinstance(c, list) else []
        for k in keys:
            out.append((c, k))
            if isinstance(c[k], (dict, list)):
                todo.append(c[k])
    return out


def _mutate_doc(draw, doc) -> None:
    slots = _slots(doc)
    if not slots:
        return
    c, k = draw(st.sampled_from(slots))
    op = draw(st.sampled_from(["delete", "retype", "number", "number", "add-key", "deep", "grow-list"]))
    if op == "delete":
        del c[k]
    elif op == "retype":
        c[k] = draw(json_values)
    elif op == "number":
        nums = [(c2, k2) for c2, k2 in slots if isinstance(c2[k2], (int, float)) and not isinstance(c2[k2], bool)]
        if nums:
            c, k = draw(st.sampled_from(nums))
        c[k] = draw(st.sampled_from(WEIRD_NUMBERS) | st.floats(-1e7, 1e7) | st.integers(-10 ** 7, 10 ** 7))
    elif op == "add-key" and isinstance(c, dict):
        c[draw(st.sampled_from(["zz", "name", "mask", "at", "layers", "to", "a\nb", "k" * 200, "a.b"]))] = draw(json_values)
    elif op == "deep":
        c[k] = DEEP + str(draw(st.sampled_from([31, 33, 40, 1000, 100_000])))
    elif op == "grow-list" and isinstance(c[k], list) and c[k]:
        c[k] = c[k] * draw(st.integers(2, 50))


def _mutate_text(draw, text: str) -> str | bytes:
    op = draw(st.sampled_from(["none", "duplicate-key", "token", "truncate", "bytes"]))
    if op == "duplicate-key":
        keys = list(re.finditer(r'"(?:[^"\\]|\\.)*"\s*:', text))
        if keys:
            m = draw(st.sampled_from(keys))
            extra = json.dumps(draw(json_values))
            text = text[:m.start()] + m.group() + " " + extra + ", " + text[m.start():]
    elif op == "token":
        nums = list(re.finditer(r"-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?", text))
        if nums:
            m = draw(st.sampled_from(nums))
            text = text[:m.start()] + draw(st.sampled_from(WEIRD_TOKENS)) + text[m.end():]
    elif op == "truncate":
        text = text[:draw(st.integers(0, len(text)))]
    elif op == "bytes":
        data = text.encode("utf-8")
        i = draw(st.integers(0, len(data)))
        return data[:i] + draw(st.binary(min_size=1, max_size=4)) + data[i:]
    return text


@st.composite
def mutated_scenes(draw):
    seed = draw(st.sampled_from(SEEDS))
    doc = copy.deepcopy(PARSED[seed])
    for _ in range(draw(st.integers(1, 3))):
        _mutate_doc(draw, doc)
    text = json.dumps(doc)
    text = re.sub(r'"\\u0001DEEP(\d+)"', lambda m: "[" * int(m.group(1)) + "]" * int(m.group(1)), text)
    return seed, _mutate_text(draw, text)


def _absolute(doc: dict, folder: str) -> dict:
    """The seed with its file paths absolute, so a mutated copy can be written anywhere."""
    def fix(p):
        return os.path.normpath(os.path.join(folder, p))
    for key in ("source", "background"):
        if isinstance(doc.get(key), str):
            doc[key] = fix(doc[key])
    for L in doc.get("layers", []):
        if isinstance(L.get("image"), str):
            L["image"] = fix(L["image"])
        if isinstance(L.get("mask"), dict) and isinstance(L["mask"].get("file"), str):
            L["mask"]["file"] = fix(L["mask"]["file"])
    return doc


PARSED = {p: _absolute(d, os.path.dirname(p)) for p, d in PARSED.items()}


def _write(seed: str, content) -> str:
    path = os.path.join(WORK, "scene.json")
    with open(path, "wb") as f:
        f.write(content if isinstance(content, bytes) else content.encode("utf-8"))
    return path


def _category(message: str) -> str:
    m = re.sub(r"'[^']*'|\d[\d.,e+-]*", "#", message.split(": ")[-1])
    return " ".join(m.split()[:4])


def _check_error(e: SceneError, path: str) -> None:
    s = str(e)
    assert "\n" not in s and s.startswith(path), s[:300]


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    shutil.rmtree(WORK, ignore_errors=True)
    report = os.environ.get("PUPPET_SWEEP_REPORT")
    if report:
        with open(report, "w") as f:
            json.dump(dict(OUTCOMES.most_common()), f, indent=1)


@PROFILE
@given(mutated_scenes())
def test_mutated_scenes_load_or_raise_scene_error(case):
    seed, content = case
    path = _write(seed, content)
    try:
        load_scene_data(path)
        OUTCOMES["read: loaded"] += 1
    except SceneError as e:
        _check_error(e, path)
        OUTCOMES["read: " + _category(e.message)] += 1


SMALL = [p for p in SEEDS if os.path.basename(p) in ("strips.json", "horse.json", "runner.json", "dress.json")]


@st.composite
def numeric_mutations(draw):
    """Mutations that still parse, so that images, masks and meshes get built."""
    seed = draw(st.sampled_from(SMALL))
    doc = copy.deepcopy(PARSED[seed])
    for _ in range(draw(st.integers(1, 3))):
        nums = [(c, k) for c, k in _slots(doc) if isinstance(c[k], (int, float)) and not isinstance(c[k], bool)
                and not (c is doc and k == "puppet")]
        c, k = draw(st.sampled_from(nums))
        c[k] = draw(st.sampled_from([0, -1, 0.5, 1e6, -1e6, 2.5, 16384]) | st.floats(-500, 1500))
    if draw(st.booleans()):
        layer = draw(st.sampled_from(doc["layers"]))
        layer["mesh"] = {"max_area": draw(st.sampled_from([0.5, 1.0, 3.0, 1e7])),
                         "min_angle": draw(st.sampled_from([1.0, 25.0, 34.0])),
                         "simplify": draw(st.sampled_from([0.0, 3.0, 1000.0]))}
    if draw(st.booleans()):
        layer = draw(st.sampled_from(doc["layers"]))
        n = draw(st.integers(3, 8))
        layer["mask"] = {"polygon": [[draw(st.floats(-50, 450)), draw(st.floats(-50, 450))] for _ in range(n)]}
    return seed, json.dumps(doc)


@BUILD_PROFILE
@given(numeric_mutations())
def test_mutated_scenes_build_or_raise_scene_error(case):
    """What ``puppet check`` does: images, masks and meshes built."""
    import puppet

    seed, text = case
    path = _write(seed, text)
    try:
        puppet.load_scene(path).summary()
        OUTCOMES["build: built"] += 1
    except SceneError as e:
        _check_error(e, path)
        OUTCOMES["build: " + _category(e.message)] += 1
