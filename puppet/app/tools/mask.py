"""Mask and pixel tools of the task script (Image, Layers steps): the canvas tools
that collect a stroke, a lasso or a rectangle, and the scene-thread jobs
that turn them into edits (one undo step each).

Strokes are rasterised on the canvas grid (the source picture's grid) and moved into the
layer image's grid by its (whole-pixel) offset. A layer made with *+* exists only in the
app until its first pixels are cloned into it (the scene refuses a mask that selects no
pixels): the first stroke creates it in front, with that mask.
"""
from __future__ import annotations

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import load_rgba
from puppet.imaging.masks import canvas_to_image, image_to_canvas
from puppet.scene.document.files import mask_rgba


# -- rasterising (any thread) -----------------------------------------------------------------
def stroke_mask(shape, points, radius: float) -> np.ndarray:
    """Round brush along the polyline ``points`` (n, 2) canvas xy: (H, W) bool."""
    import cv2

    out = np.zeros(shape, np.uint8)
    pts = np.round(np.asarray(points, float).reshape(-1, 2)).astype(np.int32)
    r = max(int(round(radius)), 1)
    if len(pts) == 1:
        cv2.circle(out, tuple(map(int, pts[0])), r, 1, -1)
    else:
        cv2.polylines(out, [pts], False, 1, thickness=2 * r, lineType=cv2.LINE_8)
        for p in (pts[0], pts[-1]):
            cv2.circle(out, tuple(map(int, p)), r, 1, -1)
    return out.astype(bool)


def polygon_mask(shape, points) -> np.ndarray:
    """Filled polygon (n >= 3 canvas points): (H, W) bool."""
    import cv2

    out = np.zeros(shape, np.uint8)
    pts = np.round(np.asarray(points, float).reshape(-1, 2)).astype(np.int32)
    if len(pts) >= 3:
        cv2.fillPoly(out, [pts], 1)
    return out.astype(bool)


def rect_mask(shape, a, b) -> np.ndarray:
    """Rectangle between canvas corners ``a`` and ``b``: (H, W) bool."""
    out = np.zeros(shape, bool)
    (xa, xb), (ya, yb) = sorted((a[0], b[0])), sorted((a[1], b[1]))
    x0, x1, y0, y1 = int(np.floor(xa)), int(np.ceil(xb)), int(np.floor(ya)), int(np.ceil(yb))
    out[max(y0, 0):max(y1, 0), max(x0, 0):max(x1, 0)] = True
    return out


# -- scene-thread jobs ----------------------------------------------------------------------
def _index(s, name):
    return next((k for k, L in enumerate(s.data.layers) if L.name == name), None)


def object_mask(s, but: str | None = None) -> np.ndarray:
    """Union of the masks of the layers that take pixels from the source (canvas grid),
    except layer ``but``: the object in a flat picture, where clones are taken from."""
    W, H = s.canvas
    out = np.zeros((H, W), bool)
    for L, im in zip(s.data.layers, s.built.images):
        if im.from_source and L.name != but:
            out |= image_to_canvas(im.mask, im.offset, (W, H))
    return out


def apply_mask(s, layer: str, shape_fn, op: str, label: str, clone: bool = False) -> str:
    """``op`` ``add`` / ``sub`` the canvas-grid mask ``shape_fn((H, W))`` to ``layer``'s mask
    (making the layer, in front, when the app had it only as an empty new layer). A
    ``clone`` takes only pixels of the object (the other source layers' masks), not the
    picture's background."""
    W, H = s.canvas
    stroke = shape_fn((H, W))
    if clone and op == "add":
        obj = object_mask(s, but=layer)
        if obj.any():
            stroke &= obj
    k = _index(s, layer)
    if k is None:  # a new layer: its first pixels
        if op != "add":
            raise SceneError(f"layer {layer!r} has no pixels yet: clone some into it first")
        if s.data.source is None:
            raise SceneError("the scene has no source picture to clone from")
        new = stroke & (load_rgba(s.data.source)[..., 3] > 0)
        if not new.any():
            raise SceneError("nothing cloned: the stroke is outside the picture")
        with s.block(f"{label} into new layer {layer}"):
            s.add_layer(layer, mask={"file": s.pending.add(mask_rgba(new), f"{layer}-mask")})
        return f"{label}: new layer {layer} ({int(new.sum())} px)"
    im = s.built.images[k]
    cut = canvas_to_image(stroke, im.offset, im.mask.shape)
    new = im.mask | cut if op == "add" else im.mask & ~cut
    if op == "add":
        new &= im.rgba[..., 3] > 0 if not im.from_source else np.ones_like(new)
    if not new.any():
        raise SceneError(f"that would leave layer {layer!r} with no pixels (remove the layer with -)")
    if np.array_equal(new, im.mask):
        return f"{label}: no change"
    with s.block(f"{label} {layer}"):
        s.set_mask_pixels(layer, new)
    return None


def split(s, layer: str, region, name: str, cut: bool) -> str:
    """Layer via Cut (``cut``) or via Copy: ``region`` (canvas polygon points, or a
    function ``(H, W) -> bool mask`` of the canvas) of ``layer`` into the new layer
    ``name`` in front of it (:meth:`puppet.scene.document.edits.Edits.split_layer`, one undo step)."""
    W, H = s.canvas
    s.split_layer(layer, region((H, W)) if callable(region) else [list(p) for p in region], name, cut=cut)
    return f"layer via {'cut' if cut else 'copy'}: {name} from {layer}" + (" (refilled behind)" if cut else "")


def select_region(app, region, label: str) -> None:
    """What a selection (lasso, rectangle, clone brush) does in the Layers step: Layer via
    Cut or Copy from the selected layer (its choice in the panel), or a clone into it (always
    into a new empty layer made with *+*). ``region``: canvas polygon points or a function
    ``(H, W) -> bool mask``."""
    sc = app.script
    layer = sc.target_layer(app)
    if layer is None:
        app.say("select a layer first (or add one with +)", "error")
        return
    shape_fn = region if callable(region) else (lambda sh: polygon_mask(sh, region))
    if sc.select_op == "clone" or layer == sc.pending or sc.step != "layers":
        app.edit(lambda s: apply_mask(s, layer, shape_fn, "add", label, True))
        return
    name, cut = sc.free_name(app), sc.select_op == "cut"
    sc.select_after = name  # the new layer is selected once it shows
    app.edit(lambda s: split(s, layer, region, name, cut))


def paint(s, layer: str, shape_fn, color) -> None:
    """Repaint ``layer``'s pixels under the canvas-grid mask ``shape_fn((H, W))`` with
    ``color`` (r, g, b) inside its mask: the layer then has its own image (refills it had
    from inpainting are kept in it)."""
    k = _index(s, layer)
    if k is None:
        raise SceneError(f"layer {layer!r} has no pixels yet: clone some into it first")
    W, H = s.canvas
    im = s.built.images[k]
    cut = canvas_to_image(shape_fn((H, W)), im.offset, im.mask.shape) & im.mask
    if not cut.any():
        raise SceneError(f"the stroke does not touch layer {layer!r}")
    rgba = im.rgba.copy()
    rgba[cut, :3] = np.asarray(color, np.uint8)[:3]
    rgba[cut, 3] = 255
    with s.block(f"paint {layer}"):
        mask = im.mask.copy()
        s.set_layer_pixels(layer, rgba)
        s.set_mask_pixels(layer, mask)


# -- canvas tools (generators, see puppet.app.tools.dispatch) ------------------------------------------
def _collect(app, press):
    """Points of a drag (canvas xy) until the release; the draft is drawn meanwhile."""
    sc = app.script
    pts = [tuple(press.xy)]
    sc.draft = pts
    ev = press
    while ev.type != "release":
        ev = yield
        if np.hypot(ev.xy[0] - pts[-1][0], ev.xy[1] - pts[-1][1]) * app.view.scale >= 2.0 or ev.type == "release":
            pts.append(tuple(ev.xy))
    sc.draft = None
    return pts


def brush_tool(app, press):
    """Brush strokes: mask add / subtract (Image, Layers clone and erase) or colour paint."""
    sc = app.script
    sc.draft_kind = "brush"
    pts = yield from _collect(app, press)
    layer, r, op = sc.target_layer(app), sc.brush / 2.0, sc.brush_op()
    if layer is None:
        app.say("select a layer first (or add one with +)", "error")
        return
    if op == "paint":
        color = tuple(int(round(c * 255)) for c in sc.color[:3])
        app.edit(lambda s: paint(s, layer, lambda sh: stroke_mask(sh, pts, r), color))
    else:
        if sc.tool == "clone-brush":
            select_region(app, lambda sh: stroke_mask(sh, pts, r), "clone brush")
            return
        label = {"add": "brush add to", "sub": "erase from"}[op]
        app.edit(lambda s: apply_mask(s, layer, lambda sh: stroke_mask(sh, pts, r), op, label))


def lasso_tool(app, press):
    """Lasso: drag around the region; the release closes it (see :func:`select_region`)."""
    sc = app.script
    sc.draft_kind = "lasso"
    pts = yield from _collect(app, press)
    if len(pts) < 3:
        app.say("drag around the region (Layer via Cut / Copy, or clone into the layer)", "error")
        return
    select_region(app, pts, "clone polygon")


def rect_tool(app, press):
    """Rectangle: clone into the selected layer (Layers), or GrabCut's box (Image)."""
    sc = app.script
    sc.draft_kind = "rect"
    pts = yield from _collect(app, press)
    a, b = pts[0], pts[-1]
    layer = sc.target_layer(app)
    if layer is None:
        app.say("select a layer first (or add one with +)", "error")
        return
    if sc.tool == "grabcut":
        x0, x1 = sorted((a[0], b[0]))
        y0, y1 = sorted((a[1], b[1]))
        if x1 - x0 < 4 or y1 - y0 < 4:
            app.say("drag a rectangle around the object for GrabCut", "error")
            return
        box = [int(round(x0)), int(round(y0)), int(round(x1 - x0)), int(round(y1 - y0))]
        app.say("GrabCut...")
        app.edit(lambda s: s.set_mask(layer, {"grabcut": box}))
        return
    select_region(app, lambda sh: rect_mask(sh, a, b), "clone rectangle")
