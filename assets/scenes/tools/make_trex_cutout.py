"""Generate ``assets/scenes/trex-cutout-inpaint.json``: parts cut out of the flat T-rex.

Run from anywhere::

    .venv/bin/python assets/scenes/tools/make_trex_cutout.py [--preview OUT.png]

The scene takes every pixel from the single flattened picture ``trex/trex.png``. The
separate layer images of the same drawing (``trex/*.PNG``) are used only to *trace*:

* each cut part (front arm ``TopArm``, jaw ``BottomHead``, ``Tail``) becomes a
  ``polygon`` mask: the outer contour of the part's alpha, dilated by ``DILATE`` px
  (``cv2.findContours`` + ``cv2.approxPolyDP``);
* the figure keeps the pixels of the picture that belong to one of the parts that are
  not cut (body, upper head, legs, back arm): ``data/trex_figure_mask_parts.png``. The
  regions only a cut part covers (the arm sticking out, the jaw, the tail) are left out
  of the figure, so moving a part away shows the background there, not a copy of it.
  Where a cut part lies over the figure (the jaw's teeth over the upper head, the tail's
  root and the arm's shoulder over the body) the figure refills the pixels by
  ``"inpaint": "telea"``.
* each part is linked to the figure by one short segment (a hinge) inside the part's
  overlap with the body, verified on both masks (eroded by 2 px) every 0.25 px.

It also writes ``docs/examples/trex-cutout-inpaint-none.json``: the same scene with
``"inpaint": "none"``, for the before/after images.
"""
from __future__ import annotations

import argparse
import json
import os

import cv2
import numpy as np
from PIL import Image, ImageDraw

from common import disk, draw_links_and_pins, dump, erode, on_mask, samples  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.dirname(HERE)
ASSETS = os.path.dirname(SCENES)
ROOT = os.path.dirname(ASSETS)
TREX = os.path.join(ASSETS, "trex")
OUT = os.path.join(SCENES, "trex-cutout-inpaint.json")
OUT_NONE = os.path.join(ROOT, "docs", "examples", "trex-cutout-inpaint-none.json")
FIGURE_MASK = os.path.join(SCENES, "data", "trex_figure_mask_parts.png")

DILATE = 2  # px added around each traced part
EDGE = 3  # px: the figure leaves out what a cut part covers this close to the outline
CUT = {"arm": "TopArm", "jaw": "BottomHead", "tail": "Tail"}  # layer name -> traced image
KEEP = ["Body", "TopHead", "LeftLeg", "RightLeg", "BottomArm"]  # what the figure is made of


def alpha(name):
    return np.array(Image.open(os.path.join(TREX, name + ".PNG")).convert("RGBA"))[..., 3] > 0






def open_pinches(m):
    """``m`` minus the few pixels around each pinched hole of its outline.

    puppet meshes a mask grown by one pixel; where the mask's outline nearly touches
    itself across a one-pixel gap, the grown mask encloses a hole whose contour shares
    points with the outer contour, and Triangle crashes (segmentation fault) on it
    (see the report). Dropping the mask pixels around such a hole opens it."""
    from puppet.geom.contour import mask_regions

    m = m.copy()
    yy, xx = np.mgrid[0:m.shape[0], 0:m.shape[1]]
    for _ in range(50):
        holes = [h for r in mask_regions(m) for h in r.holes]
        if not holes:
            return m
        for h in holes:
            c = h.mean(0) - 0.5
            m &= ~((xx - c[0]) ** 2 + (yy - c[1]) ** 2 <= 2.5 ** 2)
    raise RuntimeError("could not open the pinched holes")


def trace(m):
    """Polygon (canvas coordinates, through pixel centres) around a mask grown by DILATE."""
    g = cv2.dilate(m.astype(np.uint8), disk(DILATE))
    cs, _ = cv2.findContours(g, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    c = max(cs, key=cv2.contourArea)
    p = cv2.approxPolyDP(c, 1.0, True)[:, 0, :]
    return [[float(x) + 0.5, float(y) + 0.5] for x, y in p]


def polygon_pixels(poly, shape):
    """The pixels puppet gives a polygon mask (centre inside, even-odd)."""
    from puppet.imaging.masks import polygon_mask

    return polygon_mask(shape, np.array(poly), (0.0, 0.0))






def hinge(ov, near, length):
    """A segment of about ``length`` px on ``ov``, through its pixel nearest ``near``,
    along the overlap's principal axis."""
    ys, xs = np.nonzero(ov)
    P = np.stack([xs + 0.5, ys + 0.5], 1)
    c = P[np.argmin(np.linalg.norm(P - np.asarray(near, float), axis=1))]
    w, V = np.linalg.eigh(np.cov((P - P.mean(0)).T))
    d = V[:, 1]
    for half in np.arange(length / 2, 1.5, -0.5):
        a, b = np.round(c - half * d, 1), np.round(c + half * d, 1)
        if on_mask(ov, samples(a, b)):
            return [[float(a[0]), float(a[1])], [float(b[0]), float(b[1])]]
    raise RuntimeError("no hinge segment fits")


def pin_at(m, want, avoid, r=3):
    ok = erode(m, r)
    ys, xs = np.nonzero(ok)
    P = np.stack([xs + 0.5, ys + 0.5], 1)
    for s in avoid:
        S = samples(*s, step=1.0)
        d = np.min(np.linalg.norm(P[:, None] - S[None], axis=2), axis=1)
        P = P[d > 6]
    p = P[np.argmin(np.linalg.norm(P - np.asarray(want, float), axis=1))]
    return [float(p[0]), float(p[1])]


def turn(p, centre, deg):
    """p turned by deg counter-clockwise as seen on screen (y down) about centre."""
    t = np.radians(deg)
    v = np.subtract(p, centre)
    x = v[0] * np.cos(t) + v[1] * np.sin(t)
    y = -v[0] * np.sin(t) + v[1] * np.cos(t)
    return [round(float(centre[0] + x), 1), round(float(centre[1] + y), 1)]


def build():
    src = np.array(Image.open(os.path.join(TREX, "trex.png")).convert("RGBA"))[..., 3] > 0
    shape = src.shape
    figure = src & np.logical_or.reduce([alpha(n) for n in KEEP])
    body = alpha("Body")
    polys, masks = {}, {}
    for name, img in CUT.items():
        polys[name] = trace(alpha(img))
        masks[name] = polygon_pixels(polys[name], shape) & src
    # The figure refills (inpaints) its pixels under the cut parts from the pixels around
    # them, and those include the picture's fully transparent pixels, which are black
    # (0, 0, 0, 0): a refilled pixel within a few px of the outline comes out dark. So the
    # figure leaves out the pixels under a cut part that are that close to the outline.
    outside = cv2.dilate((~src).astype(np.uint8), disk(EDGE)).astype(bool)
    figure &= ~(np.logical_or.reduce(list(masks.values())) & outside)
    figure = open_pinches(figure)
    Image.fromarray(np.where(figure, 255, 0).astype(np.uint8), "L").save(FIGURE_MASK, optimize=True)
    # hinges: near where each part leaves the body
    near = {"arm": (199, 260), "jaw": (200, 150), "tail": (372, 300)}
    length = {"arm": 10, "jaw": 14, "tail": 24}
    links = []
    for name in CUT:
        ov = erode(masks[name] & figure & body, 2)
        seg = hinge(ov, near[name], length[name])
        S = samples(*seg)
        assert on_mask(masks[name], S) and on_mask(figure, S)
        links.append({"layers": ["figure", name], "segments": [seg]})
    segs = {L["layers"][1]: L["segments"][0] for L in links}
    allsegs = list(segs.values())
    pins = [
        {"name": "hip", "layer": "figure", "at": pin_at(figure, (300, 300), allsegs)},
        {"name": "head", "layer": "figure", "at": pin_at(figure, (150, 75), allsegs)},
        {"name": "foot_l", "layer": "figure", "at": pin_at(figure, (232, 450), allsegs)},
        {"name": "foot_r", "layer": "figure", "at": pin_at(figure, (330, 450), allsegs)},
        {"name": "hand", "layer": "arm", "at": pin_at(masks["arm"], (124, 251), allsegs)},
        {"name": "chin", "layer": "jaw", "at": pin_at(masks["jaw"], (70, 160), allsegs)},
        {"name": "tail_tip", "layer": "tail", "at": pin_at(masks["tail"], (560, 305), allsegs)},
    ]
    P = {p["name"]: p["at"] for p in pins}
    jaw_hinge = np.mean(segs["jaw"], axis=0)
    poses = {
        # the jaw drops open: the teeth go with it and the upper head shows its refill
        "roar": {"chin": turn(P["chin"], jaw_hinge, 32)},
        # the front arm goes up, far from the chest
        "reach": {"hand": turn(P["hand"], np.mean(segs["arm"], axis=0), -60)},
        # the tail swings up, its root turns off the body
        "swish": {"tail_tip": [530, 175]},
        "all": {"chin": turn(P["chin"], jaw_hinge, 32), "hand": turn(P["hand"], np.mean(segs["arm"], axis=0), -60), "tail_tip": [530, 175]},
    }
    scene = {
        "puppet": 1,
        "background": [255, 255, 255, 255],
        "source": "../trex/trex.png",
        "layers": [
            {"name": "figure", "mask": {"file": "data/trex_figure_mask_parts.png"}, "inpaint": "telea"},
            {"name": "tail", "mask": {"polygon": polys["tail"]}},
            {"name": "jaw", "mask": {"polygon": polys["jaw"]}},
            {"name": "arm", "mask": {"polygon": polys["arm"]}},
        ],
        "links": links,
        "pins": pins,
        "poses": poses,
        "animation": {"fps": 24, "keys": [
            {"time": 0.0, "pose": "rest"},
            {"time": 0.5, "pose": "roar", "ease": "smooth"},
            {"time": 1.0, "pose": "reach", "ease": "smooth"},
            {"time": 1.5, "pose": "swish", "ease": "smooth"},
            {"time": 2.0, "pose": "all", "ease": "smooth"},
            {"time": 2.5, "pose": "rest", "ease": "smooth"},
        ]},
    }
    return scene, masks, figure



def none_variant(scene):
    """The same scene seen from docs/examples/, with no inpainting."""
    v = json.loads(json.dumps(scene))
    v["source"] = "../../assets/trex/trex.png"
    v["layers"][0]["mask"]["file"] = "../../assets/scenes/data/trex_figure_mask_parts.png"
    v["layers"][0]["inpaint"] = "none"
    return v


def preview(scene, masks, figure, path):
    im = Image.open(os.path.join(TREX, "trex.png")).convert("RGBA")
    bg = Image.new("RGBA", im.size, (255, 255, 255, 255))
    bg.alpha_composite(im)
    a = np.array(bg)
    a[figure & ~np.logical_or.reduce(list(masks.values()))] //= 2
    bg = Image.fromarray(a)
    d = ImageDraw.Draw(bg)
    for L in scene["layers"][1:]:
        d.polygon([tuple(p) for p in L["mask"]["polygon"]], outline=(255, 0, 0, 255))
    draw_links_and_pins(d, scene, link=(0, 0, 255, 255), pin=(0, 0, 0, 255), width=2)
    bg.save(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preview", help="also write the traced polygons, links and pins over the picture")
    args = ap.parse_args()
    scene, masks, figure = build()
    with open(OUT, "w") as f:
        f.write(dump(scene))
    os.makedirs(os.path.dirname(OUT_NONE), exist_ok=True)
    with open(OUT_NONE, "w") as f:
        f.write(dump(none_variant(scene)))
    print("wrote", os.path.relpath(OUT), os.path.relpath(OUT_NONE), os.path.relpath(FIGURE_MASK))
    if args.preview:
        preview(scene, masks, figure, args.preview)


if __name__ == "__main__":
    main()
