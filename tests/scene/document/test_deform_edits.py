"""Edits of issue 22's deformation options: layer mode, painted stiffness, starch pin
radius, hinge points, patch polygons, link strength; each one undo step, saved and
reloaded the same, and changing the solve."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.errors import SceneError
from puppet.scene.document.core import Document
from tests.scene.document.test_edits import bars, reloaded, same_layers, three_bars  # noqa: F401


def band(doc, name="b", value=255):
    im = doc.built.images[[L.name for L in doc.data.layers].index(name)]
    g = np.zeros(im.mask.shape, np.uint8)
    g[:, 10:60] = value
    return g


EDITS = [
    ("layer mode", lambda d: d.set_layer("c", deformer={"mode": "similar"})),
    ("scene mode", lambda d: d.set_deformer(mode="distort")),
    ("stiffness pixels", lambda d: d.set_stiffness_pixels("b", band(d))),
    ("starch radius", lambda d: (d.add_pin("s1", "a", (60, 20), kind="starch"), d.set_pin_radius("s1", 25))[1]),
    ("hinge", lambda d: d.add_link_point("b", "c", (90, 70))),
    ("patch", lambda d: d.add_link_polygon("b", "c", [(80, 64), (100, 64), (100, 76), (80, 76)])),
    ("strength", lambda d: d.set_link_strength("b", "c", 0.25)),
]


@pytest.mark.parametrize("name,edit", EDITS, ids=[e[0] for e in EDITS])
def test_each_edit_is_one_step_and_saves(bars, tmp_path, name, edit):  # noqa: F811
    doc = Document.load(bars)
    doc.set_active_pose("up")
    before = doc.to_dict()
    assert edit(doc) is True
    after = doc.to_dict()
    assert after != before
    edited = doc.layers()
    if name != "starch radius":  # that one is two edits (add the pin, set its radius)
        assert doc.undo()
        assert doc.to_dict() == before
        assert doc.redo()
        assert doc.to_dict() == after
    again = reloaded(doc, tmp_path)
    again.set_active_pose("up")
    same_layers(again.layers(), edited)


def test_fields_land_where_the_format_says(bars):  # noqa: F811
    doc = Document.load(bars)
    doc.set_layer("c", deformer={"mode": "rigid"})
    doc.add_link_point("b", "c", (90, 70))
    with pytest.raises(SceneError, match="not inside both"):  # a (y 10..30) and b (y 60..80) do not overlap
        doc.add_link_point("a", "b", (60, 55))
    doc.set_link_strength("b", "c", 0.5)
    d = doc.to_dict()
    assert d["layers"][2]["deformer"] == {"mode": "rigid"}
    bc = next(k for k in d["links"] if set(k["layers"]) == {"b", "c"})
    assert bc["points"] == [[90.0, 70.0]] and bc["strength"] == 0.5 and len(bc["segments"]) == 1
    doc.set_link_strength("b", "c", 1.0)
    assert "strength" not in next(k for k in doc.to_dict()["links"] if set(k["layers"]) == {"b", "c"})


def test_refused_edits_change_nothing(bars):  # noqa: F811
    doc = Document.load(bars)
    before = doc.to_dict()
    with pytest.raises(SceneError):
        doc.set_layer("c", deformer={"mode": "bendy"})
    with pytest.raises(SceneError):
        doc.set_link_strength("b", "c", 1.5)
    with pytest.raises(SceneError):
        doc.set_link_strength("a", "c", 0.5)  # no such link
    with pytest.raises(SceneError):
        doc.add_link_polygon("b", "c", [(80, 64), (90, 64), (100, 64)])  # no area
    with pytest.raises(SceneError):
        doc.set_pin_radius("a1", 10)  # an interior pin has no radius
    assert doc.to_dict() == before


def test_painting_a_band_stiff_reduces_its_distortion(bars):  # noqa: F811
    from tests.scene.test_fit_modes import distortion

    doc = Document.load(bars)
    doc.set_target("b1", (20, 40), pose="up")  # b bends: its left end up, c1's end up
    doc.set_active_pose("up")

    def band_distortion():
        r = doc.layers()[1]  # layer b
        cx = r.rest[r.triangles].mean(1)[:, 0]
        return distortion(r.rest, r.deformed, r.triangles, (cx > 12) & (cx < 58))

    soft = band_distortion()
    doc.set_stiffness_pixels("b", band(doc))
    stiff = band_distortion()
    assert stiff < 0.5 * soft
    doc.set_stiffness_pixels("b", np.zeros_like(band(doc)))  # all zero removes it
    assert "stiffness" not in doc.to_dict()["layers"][1]
