"""Re-importing changed art into a rigged scene (``puppet init ART --update``).

Layers are matched by name. A matched layer gets the new pixels, offset and an alpha
mask and keeps everything else (mesh options, inpaint, exterior, order) with its pins,
links, poses and keys; a pin that now falls outside its layer is moved to the nearest
pixel well inside it (two pixels from the edge where the layer is that thick) and
reported. Layers of the art that the scene lacks are added at their stacking place (the
art's order); layers of the scene the art no longer has are removed with their pins
(and those pins' entries in poses, keys and bones) and links, and listed. A link whose
segment no longer lies inside both layers is removed and reported.
"""
from __future__ import annotations

import numpy as np

from puppet.imaging.layered import ArtLayer, LayeredArt


def merge(old: dict, art: LayeredArt, entries: dict, res) -> dict:
    """The scene ``old`` (paths absolute) with the layers of ``art`` (their new scene
    entries in ``entries``, by name); fills ``res.replaced/added/removed/notes``."""
    doc = dict(old)
    doc["canvas"] = list(art.size)
    by_name = {L["name"]: L for L in old.get("layers", [])}
    layers = []
    for lay in art.layers:
        if lay.name in by_name:
            L = dict(by_name[lay.name])
            L.update(entries[lay.name])
            res.replaced.append(lay.name)
        else:
            L = entries[lay.name]
            res.added.append(lay.name)
        layers.append(L)
    doc["layers"] = layers
    res.removed = [n for n in by_name if n not in entries]
    if res.removed:
        res.notes.append("layer(s) no longer in the art, removed with their pins and links: "
                         + ", ".join(res.removed))
    art_layers = {lay.name: lay for lay in art.layers}
    _pins(doc, art_layers, res)
    _links(doc, art_layers, res)
    return doc


def inside(lay: ArtLayer, x: float, y: float) -> bool:
    """Whether canvas point (x, y) is on a pixel of the layer (alpha > 0)."""
    c, r = int(np.floor(x - lay.offset[0])), int(np.floor(y - lay.offset[1]))
    h, w = lay.rgba.shape[:2]
    return 0 <= r < h and 0 <= c < w and bool(lay.rgba[r, c, 3] > 0)


def nearest_inside(lay: ArtLayer, x: float, y: float, margin: int = 2) -> tuple[float, float]:
    """The centre of the layer's pixel nearest (x, y) among those at least ``margin``
    pixels inside (all its pixels when none is)."""
    import cv2

    mask = (lay.rgba[..., 3] > 0).astype(np.uint8)
    inner = cv2.erode(mask, np.ones((2 * margin + 1, 2 * margin + 1), np.uint8), borderValue=0)
    rows, cols = np.nonzero(inner if inner.any() else mask)
    px, py = x - lay.offset[0] - 0.5, y - lay.offset[1] - 0.5
    i = int(np.argmin((cols - px) ** 2 + (rows - py) ** 2))
    return float(cols[i]) + 0.5 + lay.offset[0], float(rows[i]) + 0.5 + lay.offset[1]


def _pins(doc: dict, layers: dict, res) -> None:
    kept, gone = [], set()
    for p in doc.get("pins", []):
        lay = layers.get(p["layer"])
        if lay is None:
            gone.add(p["name"])
            continue
        if p.get("kind", "interior") != "exterior" and not inside(lay, *p["at"]):
            x, y = nearest_inside(lay, *p["at"])
            res.notes.append(f"pin {p['name']!r} at ({p['at'][0]:g}, {p['at'][1]:g}) is outside layer "
                             f"{lay.name!r} now: moved to ({x:g}, {y:g})")
            p = dict(p, at=[x, y])
        kept.append(p)
    if "pins" in doc:
        doc["pins"] = kept
    if gone:
        res.notes.append(f"{len(gone)} pin(s) removed with their layers: " + ", ".join(sorted(gone)))
    removed = set(res.removed)
    _forget(doc, lambda name: name in gone or name.split(":ext")[0] in removed and ":ext" in name)


def _forget(doc: dict, dropped) -> None:
    """Drop the named pins from poses, animation keys and bones."""
    for name, pose in list(doc.get("poses", {}).items()):
        doc["poses"][name] = {k: v for k, v in pose.items() if not dropped(k)}
    anim = doc.get("animation")
    if isinstance(anim, dict):
        for key in anim.get("keys", []):
            if isinstance(key.get("pins"), dict):
                key["pins"] = {k: v for k, v in key["pins"].items() if not dropped(k)}
    if "bones" in doc:
        doc["bones"] = [b for b in doc["bones"] if not (dropped(b[0]) or dropped(b[1]))]


def _links(doc: dict, layers: dict, res) -> None:
    kept = []
    for link in doc.get("links", []):
        a, b = link["layers"]
        if a not in layers or b not in layers:
            continue  # listed with the removed layers
        pts = [pt for seg in link.get("segments", []) for pt in seg] + list(link.get("points", []))
        if all(inside(layers[a], *pt) and inside(layers[b], *pt) for pt in pts):
            kept.append(link)
        else:
            res.notes.append(f"link {a} - {b}: no longer inside both layers; removed")
    if "links" in doc:
        doc["links"] = kept
