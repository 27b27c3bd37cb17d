"""Blend modes baked into pixels: a layer with a blend mode composited into the imported
layers below it, so that the puppet (which draws every layer normal) shows what the
file shows where those layers are opaque or alone."""
from __future__ import annotations

import numpy as np

from puppet.imaging.layered.art import ArtLayer, LayeredArt, cropped, to_uint8, unique

#: Separable blends over floats (backdrop Cb, source Cs), by ORA composite-op and Krita
#: compositeop names.
SEPARABLE = {
    "multiply": lambda b, s: b * s,
    "screen": lambda b, s: b + s - b * s,
    "darken": np.minimum,
    "lighten": np.maximum,
    "overlay": lambda b, s: np.where(b <= 0.5, 2 * b * s, 1 - 2 * (1 - b) * (1 - s)),
    "hard-light": lambda b, s: np.where(s <= 0.5, 2 * b * s, 1 - 2 * (1 - b) * (1 - s)),
    "difference": lambda b, s: np.abs(b - s),
    "plus": lambda b, s: np.minimum(b + s, 1.0),
}
_KRITA = {"hard_light": "hard-light", "diff": "difference", "add": "plus"}


def separable(op: str):
    """The blend of an ORA ``svg:...`` or Krita composite op, None when not one of these."""
    op = op.removeprefix("svg:")
    return SEPARABLE.get(_KRITA.get(op, op))


def add_blended(art: LayeredArt, taken: set, name: str, op: str, func, rgba: np.ndarray, offset) -> None:
    """A layer with blend ``func`` (None: refused, skipped): baked into ``art.layers``
    (:func:`bake_down`), what covers none of them appended as a layer; one note."""
    if func is None:
        art.notes.append(f"{name}: blend mode {op} refused (not supported); layer skipped")
        return
    rest, into = bake_down(art.layers, rgba, offset, func)
    kept = "; the rest kept as a normal layer" if rest[..., 3].any() else ""
    art.notes.append(f"{name}: blend mode {op} baked into {', '.join(map(repr, into)) or 'nothing'}{kept}")
    lay = cropped(unique(name, taken), rest, offset) if rest[..., 3].any() else None
    if lay is not None:
        art.layers.append(lay)


def bake_down(layers: list[ArtLayer], rgba: np.ndarray, offset, func) -> tuple[np.ndarray, list[str]]:
    """Blend ``rgba`` into ``layers`` (back to front), each pixel into the frontmost layer
    that has it (exact where that layer is the only one there or is opaque). Returns what
    covers none of them and the names of the layers changed."""
    rest, into = rgba, []
    x0, y0 = offset
    x1, y1 = x0 + rgba.shape[1], y0 + rgba.shape[0]
    for below in reversed(layers):
        if not below.visible:  # a hidden layer is not in the file's composite
            continue
        bx0, by0, bx1, by1 = below.bounds
        if bx0 >= x1 or bx1 <= x0 or by0 >= y1 or by1 <= y0:
            continue
        before = int((rest[..., 3] > 0).sum())
        rest = bake_onto(below, rest, offset, func)
        if int((rest[..., 3] > 0).sum()) != before:
            into.append(below.name)
        if not rest[..., 3].any():
            break
    return rest, into


def bake_onto(below: ArtLayer, rgba: np.ndarray, offset, func, *, atop: bool = False) -> np.ndarray:
    """Composite ``rgba`` at ``offset`` into ``below`` with the blend ``func(Cb, Cs)``
    (floats in [0, 1], (h, w, 3)), inside ``below``'s pixels only, as source-over with
    blending (W3C Compositing): a_o = a_s + a_b (1 - a_s), C_o = (a_s (1 - a_b) C_s +
    a_s a_b B(C_b, C_s) + (1 - a_s) a_b C_b) / a_o. Returns the rest: ``rgba`` (a copy)
    with its pixels over ``below`` made transparent (over nothing a blend draws as normal).
    ``atop``: as a clipping layer, a_o = a_b and C_o = a_s B(C_b, C_s) + (1 - a_s) C_b."""
    rest = rgba.copy()
    bx0, by0, bx1, by1 = below.bounds
    sx0, sy0 = offset
    sx1, sy1 = sx0 + rgba.shape[1], sy0 + rgba.shape[0]
    x0, y0, x1, y1 = max(bx0, sx0), max(by0, sy0), min(bx1, sx1), min(by1, sy1)
    if x0 >= x1 or y0 >= y1:
        return rest
    dst = below.rgba[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0]
    src = rgba[y0 - sy0:y1 - sy0, x0 - sx0:x1 - sx0].astype(np.float32) / 255.0
    cb, ab = dst[..., :3].astype(np.float32) / 255.0, dst[..., 3:].astype(np.float32) / 255.0
    cs, a = src[..., :3], src[..., 3:]
    if atop:
        ao, mixed = ab, a * np.asarray(func(cb, cs), np.float32) + (1 - a) * cb
    else:
        ao = a + ab * (1 - a)
        mixed = a * (1 - ab) * cs + a * ab * np.asarray(func(cb, cs), np.float32) + (1 - a) * ab * cb
        mixed = np.divide(mixed, ao, out=np.zeros_like(mixed), where=ao > 0)
    covered = dst[..., 3] > 0
    dst[covered] = to_uint8(np.concatenate([mixed, ao], axis=2))[covered]
    rest[y0 - sy0:y1 - sy0, x0 - sx0:x1 - sx0, 3][covered] = 0
    return rest
