"""The solve cache tells automatic exterior points apart by where they rest, not only by
their names: a new ``beta`` that gives as many points elsewhere is solved again (found by
helper F on the dress: the old points came back, and posing the new ones folded 337
triangles)."""
from __future__ import annotations

import os

import numpy as np

import puppet

DRESS = os.path.join(os.path.dirname(__file__), "..", "..", "..", "assets", "noto-emoji", "emoji_u1f457.png")


def test_a_new_beta_with_as_many_points_is_solved_again(make_scene):
    s = {"puppet": 1, "source": os.path.abspath(DRESS),
         "layers": [{"name": "dress", "mesh": {"max_area": 400}, "exterior": {"auto": True, "beta": 12}}],
         "pins": [{"name": "waist", "layer": "dress", "at": [250, 189]}]}
    doc = puppet.load_scene(make_scene(s))
    first = doc.layers("rest")[0].exterior
    for beta in (16, 8, 6, 4):  # one of these gives the same number of points elsewhere
        doc.set_layer("dress", exterior={"auto": True, "beta": beta})
        rest = doc.built.exterior[0].rest
        if len(rest) == len(first) and not np.allclose(rest, np.array(list(first.values()))):
            break
    else:
        raise AssertionError("no beta gave as many points elsewhere")
    shown = np.array(list(doc.layers("rest")[0].exterior.values()))
    np.testing.assert_allclose(shown, rest, atol=1e-9)
