"""Issue 8, parts 3 and 5: what JSON allows but a scene cannot mean, and inputs that would
exhaust memory or hang, are refused through the real CLI (``python -m puppet check``):
exit 2, exactly one stderr line naming the file and the JSON path, no traceback.

One case of each class runs as a subprocess (a few at a time, in a module fixture); the
variants of a class run in this process through ``puppet.cli.main``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from puppet.cli import main
from tests.conftest import ROOT, bar_image, bar_scene, write_rgba

DEEP = 100_000


def _scene(**changes) -> dict:
    s = bar_scene()
    for path, value in changes.items():
        d = s
        keys = path.split("__")
        for k in keys[:-1]:
            d = d[int(k)] if isinstance(d, list) else d[k]
        last = keys[-1]
        if isinstance(d, list):
            d[int(last)] = value
        else:
            d[last] = value
    return s


def _text(s: dict, old: str, new: str) -> str:
    t = json.dumps(s)
    assert old in t, (old, t)
    return t.replace(old, new, 1)


def _zigzag(n: int, height: float) -> list:
    return [[10 + 0.01 * i, 0.0 if i % 2 else height] for i in range(n)]


# id -> (scene text or bytes or special, JSON path named (None: file-level), words in the message)
def _cases(folder: str) -> dict:
    base = json.dumps(bar_scene())
    layer0 = '"name": "bar", "image": "bar.png"'
    big = bar_scene()
    big["layers"][0]["image"] = "big.png"
    big["layers"][0]["mesh"] = {"max_area": 0.5}
    return {
        # part 3: JSON a scene cannot mean
        "duplicate-nested": (_text(bar_scene(), layer0, layer0 + ', "image": "other.png"'),
                             "layers[0].image", "duplicate key 'image'"),
        "duplicate-top": ('{"puppet": 1, ' + base[1:], "puppet", "duplicate key 'puppet'"),
        "duplicate-pose-pin": (_text(bar_scene(), '"right": [100, 5]', '"right": [100, 5], "right": [1, 1]'),
                               "poses.bend.right", "duplicate key 'right'"),
        "nan": (_text(bar_scene(), '"at": [15, 20]', '"at": [NaN, 20]'), "pins[0].at[0]", "NaN"),
        "infinity": (_text(bar_scene(), '"right": [100, 5]', '"right": [100, -Infinity]'),
                     "poses.bend.right[1]", "-Infinity"),
        "huge-int": (_text(bar_scene(), '"canvas": [120, 40]', '"canvas": [1' + "0" * 400 + ', 40]'),
                     "canvas[0]", "too large"),
        "int-beyond-2^53": (_text(bar_scene(), '"at": [15, 20]', '"at": [9007199254740993, 20]'),
                            "pins[0].at[0]", "2^53"),
        "float-overflow": (_text(bar_scene(), '"at": [105, 20]', '"at": [105, 20], "depth": 1e999'),
                           "pins[1].depth", "too large for a float"),
        "deep-nesting": (_text(bar_scene(), '"at": [15, 20]', '"at": ' + "[" * DEEP + "]" * DEEP),
                         "pins[0].at" + "[0]" * 29, "nested deeper than 32"),
        "deep-unclosed": ('{"puppet": 1, "layers": ' + "[{\"a\": " * DEEP, "layers" + "[0].a" * 15 + "[0]", "nested deeper"),
        "invalid-json-inside": (_text(bar_scene(), '"name": "left",', '"name": "left",,'),
                                "pins[0]", "invalid JSON at line 1"),
        # numbers a scene accepts are bounded
        "offset-range": (json.dumps(_scene(layers__0__offset=[-2e6, 0])), "layers[0].offset[0]", ">= -1e+06"),
        "pose-range": (json.dumps(_scene(poses__bend__right=[100, 1e300])), "poses.bend.right[1]", "<= 1e+06"),
        "pin-range": (json.dumps(_scene(pins__0__at=[1e7, 20])), "pins[0].at[0]", "<= 1e+06"),
        "order-range": (json.dumps(_scene(layers__0__order=-1e12)), "layers[0].order", ">= -1e+06"),
        "canvas-range": (json.dumps(_scene(canvas=[1e300, 40])), "canvas[0]", "<= 16384"),
        "polygon-points": (json.dumps(_scene(layers__0__mask={"polygon": [[1, 1]] * 100_001})),
                           "layers[0].mask.polygon", "at most 100000"),
        "polygon-intricate": (json.dumps(_scene(layers__0__mask={"polygon": _zigzag(1000, 16000)})),
                              "layers[0].mask.polygon", "too intricate"),
        # part 5: meshing bounded before Triangle runs
        "mesh-too-fine": (json.dumps(big), "layers[0].mesh.max_area", "would make about"),
        "link-too-long": (json.dumps(_scene(layers=[{"name": "bar", "image": "bar.png", "mesh": {"max_area": 0.5}},
                                                    {"name": "b2", "image": "bar.png"}],
                                            links=[{"layers": ["bar", "b2"],
                                                    "segments": [[[-1e6, -1e6], [-9e5, 1e6]]]}])),
                          "links[0].segments[0]", "no part of the segment lies inside"),
        # scene files that are not files of text
        "huge-file": ("HUGE", None, "too large for a scene file"),
        "not-utf8": (b'{"puppet": 1, "layers": [{"name": "\xff\xfe"}]}', None, "UTF-8"),
        "folder": ("FOLDER", None, "is a folder"),
        "fifo": ("FIFO", None, "not a regular file"),
        "device": ("DEVICE", None, "not a regular file"),
        "empty": ("", None, "invalid JSON at line 1 column 1"),
        # images that are not regular files (no hang)
        "image-fifo": (json.dumps(_scene(layers__0__image="pipe.png")), "layers[0].image", "not a regular file"),
        "image-device": (json.dumps(_scene(layers__0__image="/dev/zero")), "layers[0].image", "not a regular file"),
        "mask-fifo": (json.dumps(_scene(layers__0__mask={"file": "pipe.png"})), "layers[0].mask.file",
                      "not a regular file"),
    }


ACCEPTED = {
    # a self-intersecting polygon is filled by the even-odd rule, not refused
    "figure-eight": json.dumps(_scene(layers__0__mask={"polygon": [[10, 10], [110, 30], [110, 10], [10, 30]]})),
    "byte-order-mark": "\ufeff" + json.dumps(bar_scene()),
    "bounds-inclusive": json.dumps(_scene(poses__bend__right=[1e6, -1e6])),
}


def _run(scene: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "puppet", "check", scene], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    folder = tmp_path_factory.mktemp("limits")
    write_rgba(folder / "bar.png", bar_image())
    write_rgba(folder / "big.png", np.full((1500, 1500, 4), (200, 40, 40, 255), np.uint8))
    os.mkfifo(folder / "pipe.png")
    paths = {}
    for name, (content, _, _) in _cases(str(folder)).items():
        p = folder / f"{name}.json"
        if content == "HUGE":
            with open(p, "wb") as f:
                f.truncate(9 * 1024 * 1024)  # sparse: no disk used
        elif content == "FOLDER":
            p.mkdir()
        elif content == "FIFO":
            os.mkfifo(p)
        elif content == "DEVICE":
            p = "/dev/zero"
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content, encoding="utf-8")
        paths[name] = str(p)
    for name, text in ACCEPTED.items():
        p = folder / f"{name}.json"
        p.write_text(text, encoding="utf-8")
        paths[name] = str(p)
    names = [n for n in paths if n in SUBPROCESS]
    with ThreadPoolExecutor(max_workers=3) as pool:
        done = dict(zip(names, pool.map(_run, [paths[n] for n in names])))
    return paths, done


CASES = _cases("")
#: one case of each class goes through a real ``python -m puppet check`` process
SUBPROCESS = {"duplicate-nested", "nan", "huge-int", "float-overflow", "deep-nesting", "offset-range",
              "huge-file", "not-utf8", "folder", "fifo", "device", "image-fifo", "mesh-too-fine",
              "figure-eight"}


class _Done:
    def __init__(self, rc: int, out: str, err: str):
        self.returncode, self.stdout, self.stderr = rc, out, err


def _outcome(results, name, capsys):
    paths, done = results
    if name in done:
        return paths[name], done[name]
    capsys.readouterr()
    rc = main(["check", paths[name]])
    out, err = capsys.readouterr()
    return paths[name], _Done(rc, out, err)


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.slow
def test_refused_with_one_line(results, name, capsys):
    path, r = _outcome(results, name, capsys)
    _, jpath, words = CASES[name]
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr[-2000:]
    line = lines[0]
    head = f"puppet: error: {path}: "
    assert line.startswith(head), line[:300]
    if jpath is not None:
        assert line[len(head):].startswith(f"{jpath}: "), line[:400]
    assert words in line, line[:400]
    assert r.stdout == ""


@pytest.mark.parametrize("name", list(ACCEPTED))
@pytest.mark.slow
def test_accepted(results, name, capsys):
    _, r = _outcome(results, name, capsys)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stderr == "" and "layer" in r.stdout


def test_source_fifo_refused_when_only_its_size_is_needed(tmp_path, capsys):
    """No layer takes pixels from ``source``: only its size is read (for the canvas),
    through the same checks; ``puppet render`` used to block on the FIFO."""
    import signal

    write_rgba(tmp_path / "bar.png", bar_image())
    os.mkfifo(tmp_path / "pipe.png")
    s = bar_scene()
    del s["canvas"]
    s["source"] = "pipe.png"
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps(s))

    def alarm(*_):
        raise TimeoutError("blocked on a FIFO")
    signal.signal(signal.SIGALRM, alarm)
    signal.alarm(30)
    try:
        rc = main(["render", str(scene), "-o", str(tmp_path / "m.png")])
    finally:
        signal.alarm(0)
    line, = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and f"{scene}: source: image" in line and "not a regular file" in line
    assert not (tmp_path / "m.png").exists()
