"""The task script's state (the layered-deformation paper's workflow, §4): which step
(Image -> Layers -> Link -> Pins -> Deform -> Pose), which tool, the brush, the drafts on the
canvas, the link pair and the tint of the step; :func:`set_step` goes to a step. The step
bar and panels that show it are :mod:`puppet.app.ui.script`; the canvas tool a step
gives a press is chosen in :mod:`puppet.app.tools.dispatch`.
"""
from __future__ import annotations

import numpy as np

from puppet.imaging.io import load_rgba
from puppet.imaging.masks import image_to_canvas

STEPS = ("image", "layers", "link", "pins", "deform", "pose")
LABELS = {"image": "Image", "layers": "Layers", "link": "Link", "pins": "Pins", "deform": "Deform", "pose": "Pose"}
TIPS = {"image": "the first layer's mask: threshold, alpha, GrabCut, brush",
        "layers": "make layers: cut (or copy) parts into new layers, clone, erase, paint, inpaint",
        "link": "tie two overlapping layers: link segments across the overlap, or a hinge or patch",
        "pins": "pins and exterior control points on the rest pose",
        "deform": "build the meshes and start posing",
        "pose": "drag pins to pose the puppet"}
#: canvas tools of each step: (tool id, label, tooltip)
TOOLS = {
    "image": [("brush-add", "Brush +", "paint pixels into the mask"),
              ("brush-sub", "Brush -", "paint pixels out of the mask"),
              ("grabcut", "GrabCut box", "drag a rectangle around the object (photos)")],
    "layers": [("lasso", "Lasso", "drag around a region: Layer via Cut / Copy from the layer, or clone into it"),
               ("clone-rect", "Rect", "drag a rectangle: Layer via Cut / Copy from the layer, or clone into it"),
               ("clone-brush", "Clone brush", "brush a region: Layer via Cut / Copy from the layer, or clone into it"),
               ("erase", "Erase", "brush pixels out of the layer"),
               ("paint", "Paint", "repaint the layer's pixels with the colour")],
    "link": [("link", "Pencil", "drag a link segment across the tinted overlap: the part inside it is kept")],
}
#: what a selection (lasso, rectangle, clone brush) does to an existing layer: (id, label, tooltip)
SELECT_OPS = [("cut", "Layer via Cut", "the part becomes a new layer in front; the layer behind loses it "
                                       "(refilled where it covered the layer's body)"),
              ("copy", "Layer via Copy", "the part is copied into a new layer in front; the layer behind keeps it"),
              ("clone", "Clone into layer", "the picture's pixels there are added to the selected layer")]


class Script:
    """Task-script state of the app (which step, tool, brush; drafts drawn on the canvas)."""

    def __init__(self):
        self.step = "pose"
        self.tool: str | None = None
        self.brush = 12.0  # diameter, canvas px
        self.color = (0.9, 0.3, 0.2, 1.0)
        self.threshold = 250.0
        self.beta = 1.0
        self.pending: str | None = None  # a new layer not yet given pixels
        self.select_op = "cut"  # what a selection does to an existing layer (SELECT_OPS)
        self.select_after: str | None = None  # a layer made by a cut / copy, selected once it shows
        self.layer_name = ""  # the rename field of the Layers step
        self.show_tint = True
        self.link_a: str | None = None
        self.link_b: str | None = None
        self.draft = None  # points of the gesture in progress
        self.draft_kind = "brush"
        self.link_preview = None  # the link segment drawn, what it keeps (a tools.link.Preview)
        self.link_masks = None  # ((snapshot version, a, b), masks as the build clips links with)
        self.rig_proposal = None  # "Rig automatically": what it found (a tools.autorig.Proposal)
        self._tint_key = None
        self._tint = None
        self._source = (None, None)

    def source(self, app) -> np.ndarray | None:
        """The scene's source picture (H, W, 4) uint8, read once per path (main thread)."""
        path = app.snap.data.source if app.snap.loaded else None
        if path is None:
            return None
        if self._source[0] != path:
            self._source = (path, load_rgba(path))
        return self._source[1]

    # -- which layer / tool --------------------------------------------------------------
    def target_layer(self, app) -> str | None:
        if self.step == "layers" and self.pending is not None and app.selected_layer in (None, self.pending):
            return self.pending
        if app.selected_layer is None and app.snap.loaded and self.step in ("image", "layers"):
            return app.snap.data.layers[0 if self.step == "image" else -1].name
        return app.selected_layer

    def free_name(self, app) -> str:
        """The first ``layerN`` (N >= 2) that no layer (nor the pending one) has."""
        names = {L.name for L in app.snap.data.layers} | {self.pending}
        k = 2
        while f"layer{k}" in names:
            k += 1
        return f"layer{k}"

    def brush_op(self) -> str:
        return {"brush-add": "add", "brush-sub": "sub", "clone-brush": "add", "erase": "sub",
                "paint": "paint"}.get(self.tool, "add")

    def link_pair(self, app):
        names = [L.name for L in app.snap.data.layers] if app.snap.loaded else []
        a = self.link_a if self.link_a in names else (names[0] if names else None)
        b = self.link_b if self.link_b in names else next((n for n in names if n != a), None)
        return (a, b) if a is not None and b is not None and a != b else (None, None)

    def layer_mask(self, app, name) -> np.ndarray | None:
        k = app.layer_index(name)
        if k is None:
            return None
        im = app.snap.images[k]
        return image_to_canvas(im.mask, im.offset, app.snap.canvas)

    def intersection(self, app) -> np.ndarray | None:
        a, b = self.link_pair(app)
        if a is None:
            return None
        ma, mb = self.layer_mask(app, a), self.layer_mask(app, b)
        return None if ma is None or mb is None else ma & mb

    def tint(self, app):
        """The tinted overlay of this step: (key, rgba (H, W, 4), offset) or None. The
        selected layer's mask (Image, Layers) or the link layers' intersection (Link)."""
        if not app.snap.loaded or self.step not in ("image", "layers", "link") or not self.show_tint:
            return None
        layer = self.target_layer(app) if self.step != "link" else None
        if layer is not None and layer in app.hidden:  # hidden to see what is behind it: no tint over that
            return None
        key = (app.snap.version, self.step, layer, self.link_pair(app) if self.step == "link" else None)
        if key != self._tint_key:
            self._tint_key = key
            m = self.intersection(app) if self.step == "link" else self.layer_mask(app, layer)
            if m is None:
                self._tint = None
            else:
                rgba = np.zeros(m.shape + (4,), np.uint8)
                rgba[m] = (40, 220, 90, 110) if self.step == "link" else (255, 40, 160, 60)
                self._tint = rgba
        return None if self._tint is None else ("\0tint", self._tint, (0.0, 0.0))


def set_step(app, step: str) -> None:
    sc = app.script
    if step not in STEPS:
        return
    sc.step = step
    sc.tool = TOOLS[step][0][0] if step in TOOLS else None
    sc.link_preview = None
    if step == "layers" and app.snap.loaded and app.selected_layer is None:
        app.selected_layer = app.snap.data.layers[-1].name
    if step in ("image", "layers", "link", "pins"):
        app.set_mode("pin")
        app.show_links = step in ("link", "pins") or app.show_links
        app.show_mesh = False
    else:
        app.set_mode("pose")
        app.show_mesh = step == "deform"
        if step == "deform":
            app.build_meshes()  # meshes and solver set-up, on the scene thread
