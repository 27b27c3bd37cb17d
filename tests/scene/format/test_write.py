"""The one scene writer (``format/write.py``): the text reads back as the same JSON, short
values stay on one line, long ones are spread one item a line, and both writers (``Document.save``
and ``puppet init``) write that form."""
from __future__ import annotations

import json
import random

from puppet.scene.document.core import Document
from puppet.scene.format.write import WIDTH, scene_text
from tests.conftest import SCENES


def test_a_small_scene_by_hand():
    doc = {"puppet": 1, "pins": [{"name": "a", "layer": "L", "at": [1, 2]}]}
    assert scene_text(doc) == '{"puppet": 1, "pins": [{"name": "a", "layer": "L", "at": [1, 2]}]}\n'
    doc["pins"] *= 3
    assert scene_text(doc) == ('{\n "puppet": 1,\n "pins": [\n'
                               '  {"name": "a", "layer": "L", "at": [1, 2]},\n'
                               '  {"name": "a", "layer": "L", "at": [1, 2]},\n'
                               '  {"name": "a", "layer": "L", "at": [1, 2]}\n ]\n}\n')


def _random_value(rng: random.Random, depth: int):
    k = rng.random()
    if depth > 4 or k < 0.4:
        return rng.choice([rng.randint(-10**6, 10**6), rng.uniform(-1e3, 1e3), None, True, "x" * rng.randint(0, 30),
                           "é\"\\/\n"])
    if k < 0.7:
        return [_random_value(rng, depth + 1) for _ in range(rng.randint(0, 8))]
    return {f"k{i}": _random_value(rng, depth + 1) for i in range(rng.randint(0, 8))}


def test_random_documents_read_back_the_same_and_keep_to_the_width():
    rng = random.Random(29)
    for _ in range(300):
        doc = {"puppet": 1, "v": _random_value(rng, 0)}
        text = scene_text(doc)
        assert json.loads(text) == doc
        for line in text.splitlines():
            # a longer line is one value that cannot be split (a scalar, or an empty list / object)
            if len(line) > WIDTH:
                tail = line.strip().rstrip(",").split(": ", 1)[-1]
                assert not (tail.startswith(("[", "{")) and len(tail) > 2), line


def test_saved_scenes_are_written_in_that_form(tmp_path):
    doc = Document.load(SCENES + "/trex-layers.json")
    doc.save(str(tmp_path / "t.json"))
    text = (tmp_path / "t.json").read_text()
    assert text == scene_text(json.loads(text))
    assert '  {"name": "hip", "layer": "body", "at": [300, 300]},\n' in text  # one pin a line
