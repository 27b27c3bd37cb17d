"""Interior distance keeps one leg from dragging the other (garment paper §3.1.1)."""
import numpy as np
import pytest

import puppet


def legs_image():
    """A body on two legs side by side, 12 px apart (held at chest and hip, as a user
    posing a leg would)."""
    a = np.zeros((220, 160, 4), np.uint8)
    a[10:90, 20:140] = (90, 60, 160, 255)     # body
    a[90:210, 30:74] = (90, 60, 160, 255)     # left leg
    a[90:210, 86:130] = (90, 60, 160, 255)    # right leg
    return a


@pytest.mark.parametrize("method,limit", [("mls", 0.08), ("arap", 0.07)])
def test_dragging_one_foot_leaves_the_other_leg(make_scene, method, limit):
    s = {"puppet": 1, "canvas": [160, 220],
         "layers": [{"name": "body", "image": "legs.png"}],
         "pins": [{"name": "chest", "layer": "body", "at": [80, 40]},
                  {"name": "hip", "layer": "body", "at": [80, 82]},
                  {"name": "foot_l", "layer": "body", "at": [52, 200]},
                  {"name": "foot_r", "layer": "body", "at": [108, 200]}],
         "deformer": {"method": method},
         "poses": {"kick": {"foot_l": [12, 160]}}}
    sc = puppet.load_scene(make_scene(s, {"legs.png": legs_image()}, name=f"{method}.json"))
    (r,) = sc.layers("kick")
    drag = np.hypot(40, 40)
    other = (r.rest[:, 0] > 86) & (r.rest[:, 1] > 95)
    moved = np.linalg.norm(r.deformed[other] - r.rest[other], axis=1)
    assert np.median(moved) < limit * drag, (method, np.median(moved) / drag)
    # and the dragged leg really moved
    own = (r.rest[:, 0] < 74) & (r.rest[:, 1] > 150)
    assert np.median(np.linalg.norm(r.deformed[own] - r.rest[own], axis=1)) > 0.3 * drag
