"""Layer via Cut / Layer via Copy: a part of a layer, chosen by a canvas region, made into
a new layer in front of it (:meth:`puppet.scene.document.edits.Edits.split_layer` calls
:func:`split_layer`).

A copy adds the new layer and leaves the layer behind as it was. A cut also takes the
part out of the layer behind (the region's pixels, and the slivers of the layer's edge it
left beside them: :func:`~puppet.imaging.cutout.cut_apart`): its mask loses the part's
pixels except where the part covered the layer's own body, found by completing the
layer's outline smoothly across the part; those pixels are refilled by the layer's inpaint
method from the layer's own pixels. A layer that takes its pixels from the scene's
source stays so (the new layer, from the same source and in front of it, is what its
``inpaint`` refills, as for any such layer; ``none`` becomes ``telea``, or ``outline``
where the art has an outline near the part), so the layers behind it keep refilling
under it too; a layer with its own image gets the refilled
picture as its new own image. New pixels and masks are stored as the app stores
painted pixels (:class:`~puppet.scene.document.files.PendingFiles`, written beside the scene on
save). Pins of the layer left on the part go with it, and so do link segments that lie
on the part only.
"""
from __future__ import annotations

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.cutout import cut_apart
from puppet.imaging.inpaint import ink_near, inpaint_layer
from puppet.imaging.io import load_rgba
from puppet.imaging.masks import canvas_to_image, polygon_mask
from puppet.scene.document.files import mask_rgba
from puppet.scene.document.history import Event

#: the refill of a cut layer whose own inpaint method is ``none`` ...
DEFAULT_REFILL = "telea"
#: ... and of one whose art has an outline near the cut (it is drawn on across the cut)
OUTLINED_REFILL = "outline"
#: link segments are checked against the masks every this many canvas pixels
SAMPLE = 0.5


def region_mask(region, canvas: tuple[int, int], offset, shape: tuple[int, int], fail) -> np.ndarray:
    """The region in a layer image's grid: (h, w) bool.

    Parameters
    ----------
    region : list of [x, y] (a polygon, canvas pixels, at least 3 points) or (H, W) bool
        (a mask of the canvas, H x W = ``canvas`` reversed).
    canvas : (W, H). offset : the layer image's canvas position. shape : its (h, w).
    fail : ``fail(message) -> SceneError``.
    """
    W, H = canvas
    try:
        arr = np.asarray(region)
    except (TypeError, ValueError, OverflowError):  # ragged lists
        arr = np.asarray([], float)
    if arr.dtype == bool:
        if arr.shape != (H, W):
            raise fail(f"a region mask must be the canvas's size {W}x{H} (as (H, W) = ({H}, {W})), "
                       f"not {arr.shape}")
        return canvas_to_image(arr, offset, shape)
    # numbers only: not strings, complex numbers or objects (ints beyond a float among them)
    P = arr.astype(float) if arr.dtype.kind in "iuf" else np.zeros((0, 0))
    if P.ndim != 2 or P.shape[1] != 2 or len(P) < 3 or not np.isfinite(P).all():
        raise fail("a region is a polygon of at least 3 finite [x, y] canvas points or a boolean mask of the "
                   f"canvas, not {_short(region)}")
    return polygon_mask(shape, P, offset)


def _short(v) -> str:
    text = " ".join(repr(v).split())  # one line: an array's repr has several
    return text if len(text) <= 60 else text[:57] + "..."


def _refill_method(L, rgba: np.ndarray, keep: np.ndarray, part: np.ndarray) -> str:
    """How a cut layer refills: its own ``inpaint`` method, or for ``none``,
    :data:`OUTLINED_REFILL` where its art has an outline near the part (``keep`` its mask
    after the cut), :data:`DEFAULT_REFILL` elsewhere."""
    if L.inpaint != "none":
        return L.inpaint
    return OUTLINED_REFILL if ink_near(rgba, keep, part & keep)[0] is not None else DEFAULT_REFILL


def _refilled(s, k: int, keep: np.ndarray, part: np.ndarray, method: str) -> np.ndarray:
    """Layer ``k``'s own image with ``part`` refilled by ``method`` from the rest of the
    layer; ``outline`` draws the outline along ``keep``, its mask after the cut: (h, w, 4)."""
    im, L = s.built.images[k], s.data.layers[k]
    base = load_rgba(L.image, scene_file=s.file, json_path=f"layers[{k}].image")
    if method != OUTLINED_REFILL:
        return inpaint_layer(base, im.mask, part, method)
    out = inpaint_layer(base, im.mask, part, DEFAULT_REFILL)  # the part's pixels off the new mask too
    return inpaint_layer(out, keep, part & keep, method)


def _on(im_mask: np.ndarray, offset, seg) -> bool:
    """Is every sample of the canvas segment ``seg`` on a pixel of ``im_mask`` (image grid at ``offset``)?"""
    p0, p1 = np.asarray(seg[0], float), np.asarray(seg[1], float)
    n = max(int(np.ceil(np.hypot(*(p1 - p0)) / SAMPLE)), 1)
    pts = p0 + np.linspace(0.0, 1.0, n + 1)[:, None] * (p1 - p0)
    j = np.floor(pts[:, 0] - offset[0]).astype(int)
    i = np.floor(pts[:, 1] - offset[1]).astype(int)
    h, w = im_mask.shape
    ok = (i >= 0) & (i < h) & (j >= 0) & (j < w)
    return bool(ok.all() and im_mask[i, j].all())


def _move_links(doc: dict, layer: str, name: str, keep: np.ndarray, part: np.ndarray, offset) -> None:
    """Link segments of ``layer`` that leave ``keep`` but lie on ``part`` go to ``name``."""
    moved: dict[str, list] = {}
    for link in doc.get("links", []):
        if layer not in link["layers"]:
            continue
        other = link["layers"][1] if link["layers"][0] == layer else link["layers"][0]
        stay = [g for g in link["segments"] if _on(keep, offset, g) or not _on(part, offset, g)]
        moved.setdefault(other, []).extend(g for g in link["segments"] if g not in stay)
        link["segments"] = stay
    doc["links"] = [k for k in doc.get("links", []) if k["segments"]]
    for other, segs in moved.items():
        if segs:
            doc["links"].append({"layers": [other, name], "segments": segs})
    if not doc["links"]:
        del doc["links"]


def split_layer(s, layer: str, region, name: str, cut: bool = True) -> bool:
    """Layer via Cut (``cut=True``) or via Copy of ``region`` of ``layer`` into a new layer
    ``name`` in front of it, as one undo step on the document ``s``. See the module doc."""
    if not isinstance(cut, (bool, np.bool_)):
        raise SceneError(f"cut is True (Layer via Cut) or False (Layer via Copy), not {cut!r}", file=s.file)
    d = s.data
    k = next((i for i, L in enumerate(d.layers) if L.name == layer), None)
    if k is None:
        raise s._fail(f"no layer named {layer!r} (layers: {', '.join(L.name for L in d.layers)})")
    if not isinstance(name, str) or not name.strip():
        raise s._fail(f"a new layer needs a name, not {name!r}")
    if any(L.name == name for L in d.layers):
        raise s._fail(f"a layer named {name!r} exists already")
    im, L = s.built.images[k], d.layers[k]
    part = region_mask(region, s.canvas, im.offset, im.mask.shape, s._fail) & im.mask
    if not part.any():
        raise s._fail(f"the region selects no pixels of layer {layer!r}")
    if cut:
        part, keep, refill = cut_apart(im.mask, part, rgb=im.rgba)
    else:
        keep, refill = im.mask, None
    if cut and not keep.any():
        raise s._fail(f"the region takes all of layer {layer!r}: nothing would be left behind "
                      "(copy it with cut=False, or rename the layer)")
    part_file = s.pending.add(mask_rgba(part), f"{name}-mask")
    if cut:
        keep_file = s.pending.add(mask_rgba(keep), f"{layer}-mask")
        method = _refill_method(L, im.rgba, keep, part)
        own = L.image is not None and refill.any()  # refilled once here; a source layer refills itself
        image_file = s.pending.add(_refilled(s, k, keep, part, method), layer) if own else None
    raw = s._layer(s._doc, layer)

    def m(doc):
        new = {"name": name, "mask": {"file": part_file}}
        if L.image is not None:
            new["image"] = raw["image"]
        for f in ("offset", "order", "mesh", "inpaint"):
            if f in raw:
                new[f] = raw[f]
        at = next(i for i, x in enumerate(doc["layers"]) if x["name"] == layer)
        doc["layers"].insert(at + 1, new)
        if not cut:
            return
        behind = doc["layers"][at]
        behind["mask"] = {"file": keep_file}
        if image_file is not None:
            behind["image"] = image_file
        elif L.image is None and behind.get("inpaint", "none") == "none":
            behind["inpaint"] = method
        for p in doc.get("pins", []):
            if p["layer"] == layer and p.get("kind", "interior") == "interior" \
                    and not _on(keep, im.offset, [p["at"], p["at"]]) and _on(part, im.offset, [p["at"], p["at"]]):
                p["layer"] = name
        if doc.get("links"):
            _move_links(doc, layer, name, keep, part, im.offset)
    verb = "cut" if cut else "copy"
    try:
        return s._edit(Event("layer", name, "mesh", f"{verb} {name} from {layer}"), m)
    except SceneError as e:  # e.g. a pose names an exterior point the new outline no longer has
        raise type(e)(f"cannot {verb} {name!r} from {layer!r}: {e.message}", file=e.file, path=e.path) from None
