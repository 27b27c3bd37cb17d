"""Renamed layers matched by content (issue 30, 3): the score of two layers, the renaming
of a scene JSON, and the pairing of gone and new layers."""
from __future__ import annotations

import numpy as np

from puppet.imaging.layered import ArtLayer, LayeredArt
from puppet.scene.make.merge import MATCH_SCORE, content_score, rename_layers, renamed_by_content
from tests.artfiles import parts


def arm():
    return parts()[0][2]


def test_the_same_pixels_score_one_and_other_pixels_low():
    a = arm()
    assert content_score(a, a) > 0.99
    inverted = a.copy()
    inverted[..., :3] = 255 - inverted[..., :3]
    assert content_score(a, inverted) < MATCH_SCORE
    head = parts()[5][2]
    assert content_score(a, head) == 0.0  # sizes too far apart


def test_a_few_pixels_more_and_a_shift_still_match():
    a = arm()
    h, w = a.shape[:2]
    b = np.zeros((h + 3, w + 2, 4), np.uint8)
    b[3:, 2:] = a  # cropped with a margin: the same pixels, moved
    assert content_score(a, b) >= MATCH_SCORE
    flipped = a[:, ::-1].copy()
    assert content_score(a, flipped) < content_score(a, b)


def test_pairs_only_gone_and_new_layers_best_first():
    a, head = arm(), parts()[5][2]
    old = {"layers": [{"name": "arm", "offset": [0, 0]}, {"name": "head", "offset": [50, 0]},
                      {"name": "kept", "offset": [0, 0]}]}
    pixels = {"arm": a, "head": head, "kept": a}
    art = LayeredArt("x.ora", (400, 400), [ArtLayer("kept", a, (0, 0)), ArtLayer("left arm", a, (0, 0)),
                                           ArtLayer("face", head, (50, 0)), ArtLayer("new", np.full((5, 5, 4), 255, np.uint8), (0, 0))])
    notes = []
    assert renamed_by_content(old, art, lambda L: pixels[L["name"]], notes) == {"arm": "left arm", "head": "face"}
    assert renamed_by_content(old, art, lambda L: None, notes) == {}  # old pixels unknown: no match


def test_rename_reaches_pins_links_poses_keys_bones_and_exterior_points():
    doc = {"layers": [{"name": "a"}, {"name": "b"}],
           "pins": [{"name": "a:end1", "layer": "a", "at": [1, 1]}, {"name": "p", "layer": "b", "at": [2, 2]}],
           "links": [{"layers": ["a", "b"], "segments": []}],
           "poses": {"up": {"a:end1": [0, 0], "a:ext2": [1, 1], "a:cage3": [2, 2], "p": [3, 3]}},
           "animation": {"keys": [{"time": 0, "pins": {"a:ext2": [0, 0]}},
                                  {"time": 1, "pose": "up", "overrides": {"a:cage1": [4, 4]}}]},
           "bones": [["a:end1", "a:ext2"]]}
    out = rename_layers(doc, {"a": "arm"})
    assert [L["name"] for L in out["layers"]] == ["arm", "b"]
    assert out["pins"][0] == {"name": "a:end1", "layer": "arm", "at": [1, 1]}  # pin names stay
    assert out["links"][0]["layers"] == ["arm", "b"]
    assert set(out["poses"]["up"]) == {"a:end1", "arm:ext2", "arm:cage3", "p"}
    assert out["animation"]["keys"][0]["pins"] == {"arm:ext2": [0, 0]}
    assert out["animation"]["keys"][1] == {"time": 1, "pose": "up", "overrides": {"arm:cage1": [4, 4]}}
    assert out["bones"] == [["a:end1", "arm:ext2"]]
    assert doc["layers"][0]["name"] == "a" and "a:ext2" in doc["poses"]["up"]  # the input is not changed
