"""Issue 30, the automatic rig (``--pins auto --links auto``): fast where all pairs were
tried, and a deadline that stops it with a note, the import going on with what was done."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import zipfile

import cv2
import numpy as np
import pytest

from puppet.imaging.layered import ArtLayer
from puppet.imaging.skeleton import auto_pins
from puppet.scene.make import auto_links
from puppet.scene.make.art import import_art
from puppet.scene.make.anatomy import propose_rig
from puppet.scene.make.auto_links import Deadline, box_pairs
from tests.conftest import ROOT
from tests.imaging.test_layered_zip import png


def blob(name, w, h, x, y):
    a = np.zeros((h, w, 4), np.uint8)
    cv2.ellipse(a, (w // 2, h // 2), (w // 2, h // 2), 0, 0, 360, (200, 100, 50, 255), -1)
    return ArtLayer(name, a, (x, y))


def overlapping(boxes) -> set[tuple[int, int]]:
    return {(i, j) for i, a in enumerate(boxes) for j, b in enumerate(boxes[i + 1:], i + 1)
            if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]}


@pytest.mark.parametrize("seed", range(6))
def test_the_sweep_finds_the_pairs_every_pair_finds(seed):
    rng = np.random.default_rng(seed)
    layers = [blob(f"l{k}", *(int(v) for v in rng.integers(6, 70, 2)), *(int(v) for v in rng.integers(0, 150, 2)))
              for k in range(int(rng.integers(2, 30)))]
    boxes = [lay.bounds for lay in layers]
    found = list(box_pairs(boxes))
    assert len(found) == len(set(found)) and set(found) == overlapping(boxes)


def test_2000_layers_apart_are_rigged_in_a_few_seconds():
    a = np.zeros((12, 12, 4), np.uint8)
    a[..., 3] = 255
    layers = [ArtLayer(f"l{i}", a, ((i % 45) * 20, (i // 45) * 20)) for i in range(2000)]
    t = time.monotonic()
    rig = propose_rig(layers, canvas=(1000, 1000))
    assert rig.links == [] and len(rig.roots) == 2000
    assert time.monotonic() - t < 20  # (every pair of overlaps tried: 7.7 s for the links alone)


def test_a_passed_deadline_stops_the_rig():
    layers = [blob(f"l{k}", 40, 40, 5 * k, 0) for k in range(30)]
    assert len(propose_rig(layers, canvas=(1000, 1000)).links) == 29
    late = Deadline(0)
    rig = propose_rig(layers, canvas=(1000, 1000), deadline=late)
    assert rig.links == [] and rig.pins == [] and late.hit


def test_a_layer_touching_its_edges_is_thinned_like_any_other():
    # OpenCV's thinning keeps every pixel on the image's edge: a full 16x16 layer gave
    # hundreds of end points (and took 30 ms to merge), a bar no ends at its middle
    assert [(p.kind, p.at) for p in auto_pins(np.ones((16, 16), bool))] == [("centre", (7.5, 7.5))]
    pins = auto_pins(np.ones((16, 60), bool))
    assert [p.kind for p in pins] == ["end", "end"] and all(p.at[1] == 7.5 for p in pins)


def many_layers_ora(path, n, spread):
    rng = np.random.default_rng(0)
    xml = "".join(f'<layer name="l{i}" src="l.png" x="{int(x)}" y="{int(y)}"/>'
                  for i, (x, y) in enumerate(rng.integers(0, spread, (n, 2))))
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("stack.xml", f'<image w="640" h="640"><stack>{xml}</stack></image>')
        z.writestr("l.png", png((200, 100, 50), (16, 16)))
    return str(path)


def test_the_deadline_stops_the_rig_with_a_note_and_the_import_goes_on(tmp_path, monkeypatch):
    monkeypatch.setattr(auto_links, "RIG_SECONDS", 0.0)
    art = many_layers_ora(tmp_path / "a.ora", 12, 100)
    res = import_art(art, str(tmp_path / "s.json"), pins="auto", links="auto")
    assert res.note_lines("a.ora")[-1] == ("puppet: note: a.ora: automatic rig stopped after 0 s: 0 pin(s) and 0 "
                                           "link(s) for the parts done (--update with --pins auto --links auto "
                                           "rigs the rest)")
    doc = json.loads((tmp_path / "s.json").read_text())
    assert len(doc["layers"]) == 12 and not doc.get("pins") and not doc.get("links")


@pytest.mark.slow
def test_1000_small_layers_with_the_automatic_rig_through_the_cli(tmp_path):
    art = many_layers_ora(tmp_path / "many.ora", 1000, 430)  # as crowded as 2000 on 600 px
    t = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "puppet", "init", art, "-o", str(tmp_path / "s.json"),
                        "--pins", "auto", "--links", "auto"], capture_output=True, text=True, timeout=400,
                       cwd=ROOT, env=dict(os.environ, PYTHONPATH=ROOT))
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr[-2000:]
    doc = json.loads((tmp_path / "s.json").read_text())
    assert len(doc["layers"]) == 1000 and doc["pins"] and doc["links"]
    assert time.monotonic() - t < 300
