"""Re-importing changed art into a rigged scene (``puppet init ART --update``).

Layers are matched by name; then an old layer whose name the art no longer has and a
new layer whose name the scene lacks are taken as one layer renamed when their pixels
agree (:func:`content_score`, after aligning them by phase correlation): the scene's
layer, its pins, links, poses, keys and bones take the new name first, and a note says
so. A matched layer gets the new pixels, offset and an alpha
mask and keeps everything else (mesh options, inpaint, exterior, order) with its pins,
links, poses and keys; a pin that now falls outside its layer is moved to the nearest
pixel well inside it (two pixels from the edge where the layer is that thick) and
reported. Layers of the art that the scene lacks are added at their stacking place (the
art's order); layers of the scene the art no longer has are removed with their pins
(and those pins' entries in poses, keys and bones) and links, and listed. A link whose
segment no longer lies inside both layers is removed and reported.
"""
from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np

from puppet.imaging.io import load_rgba
from puppet.imaging.layered import ArtLayer, LayeredArt
from puppet.scene.format.physics import drop_chain_pins

#: an automatic exterior point or a cage handle: named after its layer
_HANDLE = re.compile(r"(?P<layer>.+):(?P<kind>ext|cage)(?P<i>\d+)")

#: Lowest :func:`content_score` for an old and a new layer to be taken as one renamed.
MATCH_SCORE = 0.9
#: Side (pixels) the two layers are shrunk to, at most, to be compared.
MATCH_SIDE = 128
#: Most (old, new) pairs compared; beyond, renamed layers are not looked for (a note says so).
MAX_PAIRS = 20_000


def merge(old: dict, art: LayeredArt, entries: dict, res, pixels: Callable | None = None) -> dict:
    """The scene ``old`` (paths absolute) with the layers of ``art`` (their new scene
    entries in ``entries``, by name); fills ``res.replaced/added/removed/notes``.
    ``pixels(layer_json)`` gives an old layer's (h, w, 4) uint8 pixels or None (default:
    its ``image`` file), for matching renamed layers by content."""
    renames = renamed_by_content(old, art, pixels or _image_of, res.notes)
    if renames:
        old = rename_layers(old, renames)
        for a, b in renames.items():
            res.notes.append(f"layer {a!r} renamed to {b!r} (matched by content)")
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
    keys_before = _key_entries(doc)
    _pins(doc, art_layers, res)
    _links(doc, art_layers, res)
    dropped = keys_before - _key_entries(doc)
    if dropped:
        res.notes.append(f"{dropped} pose target(s) and key entries of removed pins dropped")
    return doc


def _image_of(L: dict) -> np.ndarray | None:
    p = L.get("image")
    if not isinstance(p, str):
        return None
    try:
        return load_rgba(p)
    except Exception:  # a missing or unreadable old image: that layer is not matched by content
        return None


def _key_entries(doc: dict) -> int:
    n = sum(len(p) for p in doc.get("poses", {}).values() if isinstance(p, dict))
    anim = doc.get("animation")
    if isinstance(anim, dict):
        n += sum(len(k["pins"]) for k in anim.get("keys", []) if isinstance(k.get("pins"), dict))
    return n


def content_score(a: np.ndarray, b: np.ndarray) -> float:
    """How well two straight-alpha RGBA layers (h, w, 4) uint8 agree, 0..1: the overlap
    (intersection over union) of their alpha after aligning them by phase correlation,
    times one less the mean colour difference where both are opaque. Layers whose sizes
    differ by more than a tenth (and 2 px) score 0."""
    import cv2  # lazy: OpenCV, for --update only

    (ha, wa), (hb, wb) = a.shape[:2], b.shape[:2]
    if abs(ha - hb) > max(2, 0.1 * max(ha, hb)) or abs(wa - wb) > max(2, 0.1 * max(wa, wb)):
        return 0.0
    H, W = max(ha, hb), max(wa, wb)
    f = min(1.0, MATCH_SIDE / max(H, W))
    size = (max(1, round(W * f)), max(1, round(H * f)))

    def prep(x: np.ndarray) -> np.ndarray:
        pad = np.zeros((H, W, 4), np.float32)
        pad[:x.shape[0], :x.shape[1]] = x / np.float32(255)
        return cv2.resize(pad, size, interpolation=cv2.INTER_AREA) if f < 1 else pad
    A, B = prep(a), prep(b)
    if A[..., 3].sum() <= 0 or B[..., 3].sum() <= 0:
        return 0.0
    (dx, dy), _ = cv2.phaseCorrelate(A[..., 3].astype(np.float64), B[..., 3].astype(np.float64))
    best = 0.0
    for s in ((0.0, 0.0), (dx, dy), (-dx, -dy)):
        if abs(s[0]) > 0.15 * size[0] + 1 or abs(s[1]) > 0.15 * size[1] + 1:
            continue
        M = np.float32([[1, 0, s[0]], [0, 1, s[1]]])
        Bs = cv2.warpAffine(B, M, size, flags=cv2.INTER_LINEAR, borderValue=(0, 0, 0, 0))
        union = np.maximum(A[..., 3], Bs[..., 3]).sum()
        iou = float(np.minimum(A[..., 3], Bs[..., 3]).sum() / union) if union > 0 else 0.0
        both = (A[..., 3] > 0.5) & (Bs[..., 3] > 0.5)
        colour = float(np.abs(A[..., :3][both] - Bs[..., :3][both]).mean()) if both.any() else 1.0
        best = max(best, iou * (1.0 - colour))
    return best


def renamed_by_content(old: dict, art: LayeredArt, pixels: Callable, notes: list[str]) -> dict[str, str]:
    """Old layer name -> new layer name, for the old layers whose names the art lacks and
    the art's layers whose names the scene lacks, paired where :func:`content_score` is at
    least :data:`MATCH_SCORE` (best pairs first; ties to the nearer offset)."""
    new_names = {lay.name for lay in art.layers}
    old_layers = [L for L in old.get("layers", []) if isinstance(L, dict)]
    old_names = {L.get("name") for L in old_layers}
    gone = [L for L in old_layers if L.get("name") not in new_names]
    fresh = [lay for lay in art.layers if lay.name not in old_names]
    if not gone or not fresh:
        return {}
    if len(gone) * len(fresh) > MAX_PAIRS:
        notes.append(f"{len(gone)} layer(s) gone and {len(fresh)} new: too many to match renamed layers "
                     f"by content (at most {MAX_PAIRS} pairs)")
        return {}
    pairs = []
    for L in gone:
        rgba = pixels(L)
        if rgba is None:
            continue
        ox, oy = (L.get("offset") or [0, 0])[:2]
        for lay in fresh:
            score = content_score(rgba, lay.rgba)
            if score >= MATCH_SCORE:
                far = float(np.hypot(lay.offset[0] - ox, lay.offset[1] - oy))
                pairs.append((-score, far, L["name"], lay.name))
    out, used = {}, set()
    for _, _, a, b in sorted(pairs):
        if a not in out and b not in used:
            out[a] = b
            used.add(b)
    return out


def rename_layers(doc: dict, renames: dict[str, str]) -> dict:
    """A copy of the scene JSON with layers renamed (old -> new) wherever a name is used:
    the layer, its pins' ``layer``, links, and its automatic exterior points and cage
    handles (``LAYER:extN``, ``LAYER:cageN``) in poses, keys (``pins`` and ``overrides``)
    and bones."""
    def pin(name: str) -> str:
        m = _HANDLE.fullmatch(name)
        if m and m.group("layer") in renames:
            return f"{renames[m.group('layer')]}:{m.group('kind')}{m.group('i')}"
        return name
    doc = dict(doc)
    doc["layers"] = [dict(L, name=renames.get(L.get("name"), L.get("name"))) if isinstance(L, dict) else L
                     for L in doc.get("layers", [])]
    if "pins" in doc:
        doc["pins"] = [dict(p, layer=renames.get(p.get("layer"), p.get("layer"))) for p in doc["pins"]]
    if "links" in doc:
        doc["links"] = [dict(k, layers=[renames.get(n, n) for n in k["layers"]]) for k in doc["links"]]
    if isinstance(doc.get("poses"), dict):
        doc["poses"] = {n: {pin(k): v for k, v in p.items()} for n, p in doc["poses"].items()}
    anim = doc.get("animation")
    if isinstance(anim, dict) and isinstance(anim.get("keys"), list):
        def key(k):
            return {f: ({pin(n): v for n, v in k[f].items()} if f in ("pins", "overrides") and isinstance(k[f], dict)
                        else k[f]) for f in k} if isinstance(k, dict) else k
        doc["animation"] = dict(anim, keys=[key(k) for k in anim["keys"]])
    if "bones" in doc:
        doc["bones"] = [[pin(b[0]), pin(b[1]), *b[2:]] for b in doc["bones"]]
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
    def dropped(name: str) -> bool:
        m = _HANDLE.fullmatch(name)
        return name in gone or (m is not None and m.group("layer") in removed)
    _forget(doc, dropped)


def _forget(doc: dict, dropped) -> None:
    """Drop the named pins from poses, animation keys, bones and physics chains."""
    for name, pose in list(doc.get("poses", {}).items()):
        doc["poses"][name] = {k: v for k, v in pose.items() if not dropped(k)}
    anim = doc.get("animation")
    if isinstance(anim, dict):
        for key in anim.get("keys", []):
            for f in ("pins", "overrides"):
                if isinstance(key.get(f), dict):
                    key[f] = {k: v for k, v in key[f].items() if not dropped(k)}
    if "bones" in doc:
        doc["bones"] = [b for b in doc["bones"] if not (dropped(b[0]) or dropped(b[1]))]
    drop_chain_pins(doc, dropped)


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
