"""The pictures of docs/app.md's "Fitting deformation" section, retaken by the tests
(headless window): a gopher-like arm lifting a drink with a segment link and with a
hinge, and the bundled dress squeezed onto a smaller person in each mode. Each also
checks what the picture is meant to show."""
from __future__ import annotations

import os

import numpy as np
import pytest

from tests.app.harness import Driver, widget
from tests.scene.test_fit_modes import area_ratio, distortion, folds

pytestmark = pytest.mark.gl

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HINGE = (203.0, 150.0)


def gopher_images():
    """A brown body with a head, and an arm holding a blue drink (RGBA)."""
    import cv2

    body = np.zeros((300, 360, 4), np.uint8)
    cv2.ellipse(body, (150, 185), (70, 100), 0, 0, 360, (150, 100, 60, 255), -1)
    cv2.circle(body, (150, 90), 52, (160, 110, 70, 255), -1)
    cv2.circle(body, (132, 78), 7, (20, 20, 20, 255), -1)
    cv2.circle(body, (170, 78), 7, (20, 20, 20, 255), -1)
    arm = np.zeros((300, 360, 4), np.uint8)
    cv2.line(arm, (190, 150), (290, 150), (120, 75, 40, 255), 26)
    cv2.circle(arm, (190, 150), 13, (120, 75, 40, 255), -1)
    cv2.rectangle(arm, (282, 112), (316, 162), (60, 120, 230, 255), -1)  # the drink
    return body, arm


def gopher_scene(link) -> dict:
    return {"puppet": 1, "canvas": [360, 300], "background": [255, 255, 255, 255],
            "layers": [{"name": "body", "image": "body.png"}, {"name": "arm", "image": "arm.png"}],
            "links": [dict({"layers": ["body", "arm"]}, **link)],
            "pins": [{"name": "foot", "layer": "body", "at": [150, 270]},
                     {"name": "head", "layer": "body", "at": [150, 80]},
                     {"name": "drink", "layer": "arm", "at": [299, 137]}],
            "poses": {"lift": {"drink": [HINGE[0] + 13, HINGE[1] - 96]}}}  # turned 90° about the hinge


@pytest.mark.parametrize("kind", ["segment", "hinge"])
def test_gopher_arm_segment_vs_hinge(make_scene, kind):

    body, arm = gopher_images()
    link = {"segments": [[[194, 146], [212, 154]]]} if kind == "segment" else {"points": [list(HINGE)]}
    d = Driver(make_scene(gopher_scene(link), {"body.png": body, "arm.png": arm}), size=(900, 640))
    try:
        d.app.show_links = True
        d.app.edit(lambda s: s.set_active_pose("lift"))
        d.settle()
        r = next(x for x in d.scene().layers() if x.name == "body")
        far = np.hypot(*(r.rest - HINGE).T) > 12
        moved = np.abs(r.deformed - r.rest)[far].max()
        a = next(x for x in d.scene().layers() if x.name == "arm")
        bent = distortion(a.rest, a.deformed, a.triangles)
        d.shot(f"deform-arm-{kind}")
        if kind == "hinge":  # the arm turns about the shared point, keeping its shape; the body stays
            assert moved <= 2.0 and bent <= 0.002  # (measured 0.45 px, 0.0003)
        else:  # the segment holds the arm's root along it: the arm bends, the shoulder follows
            assert moved > 3.0 and bent > 0.005  # (measured 5.9 px, 0.015)
    finally:
        d.close()


def dress_app():
    path = os.path.join(ROOT, "assets", "scenes", "dress-garment.json")
    d = Driver(path, size=(1000, 760))
    person = os.path.join(ROOT, "assets", "noto-emoji", "emoji_u1f9cd.png")
    d.app.edit(lambda s: s.set_underlay(person, opacity=0.6, offset=(-5, -150)))
    c = np.array([250.0, 30.0])

    def squeeze(s):  # the whole dress to 75 % about the straps' middle: onto the smaller person
        with s.block("fit the dress"):
            s.add_pose("fit")
            for p in s.data.pins:
                s.set_target(p.name, c + 0.75 * (np.asarray(p.at) - c))
    d.app.edit(squeeze)
    d.settle()
    d.click(*widget("header:Deform"))
    d.settle()
    return d


def test_dress_squeezed_in_each_mode():
    d = dress_app()
    try:
        ratios = {}
        for mode in ("rigid", "similar", "distort"):
            d.click(*widget("combo:scene mode"))
            d.frame(3)
            d.click(*widget(f"scene mode:{mode}"))  # the current one: the popup closes, no edit
            d.settle()
            assert d.scene().data.deformer.mode == mode
            d.w.win.dispatch_event("on_mouse_motion", 990, 10, 0, 0)  # the pointer off the canvas
            d.frame(3)
            d.shot(f"deform-dress-{mode}")
            res = d.scene().layers()
            ratios[mode] = area_ratio(res)
            if mode == "similar":
                assert folds(res) == 0
        assert abs(ratios["similar"] - 0.5625) < 0.05  # evenly to 75 % x 75 %
        assert ratios["rigid"] > ratios["similar"] + 0.1  # rigid keeps its area: it crumples instead
    finally:
        d.close()


@pytest.mark.slow
def test_dress_skirt_band_painted_stiff():
    """The bundled 'sway' pose in rigid mode, a band of the skirt painted stiff with the
    brush (heat map shown while the brush is the tool): the band keeps its shape."""
    from puppet.app.model.pick import shown_point

    d = dress_app()
    try:
        d.app.edit(lambda s: s.set_active_pose("sway"))
        d.settle()

        def band():
            r = d.scene().layers()[0]
            c = r.rest[r.triangles].mean(1)
            sel = (c[:, 1] > 205) & (c[:, 1] < 295)
            return distortion(r.rest, r.deformed, r.triangles, sel)

        soft = band()
        d.click(*widget("deform-tool:brush"))  # paints the layer under the stroke
        d.frame(2)
        d.app.deform.brush = 40.0
        r = d.scene().layers()[0]
        for y in (215.0, 250.0, 285.0):
            xs = np.r_[np.linspace(250.0, 100.0, 6), np.linspace(100.0, 400.0, 12)]  # pressed on the dress
            d.drag_path([d.screen_of(shown_point(r, (x, y))) for x in xs])
            d.settle()
        assert band() < 0.4 * soft  # (the scene API with the band painted exactly: 0.22)
        d.w.win.dispatch_event("on_mouse_motion", 990, 10, 0, 0)
        d.frame(3)
        d.shot("deform-stiffness")
    finally:
        d.close()
