"""OpenRaster (``.ora``, Krita, GIMP, MyPaint...): a zip of PNG layers and ``stack.xml``.

``stack.xml`` lists layers top first; ``<stack>`` elements are groups. Read: each
``<layer>``'s PNG at its ``x``, ``y``, with its ``opacity`` (times its groups'),
``visibility`` and name; ``composite-op`` other than ``svg:src-over`` is baked into the
layers below with the matching separable blend (multiply, screen, overlay, darken,
lighten, ...; see :mod:`puppet.imaging.layered.blend`), else the layer is skipped
with a note.
"""
from __future__ import annotations

import numpy as np

from puppet.errors import ImageError
from puppet.imaging.layered import (LayeredArt, check_size, cropped, over, scale_alpha, split_tags,
                                    unique)
from puppet.imaging.layered.zipped import open_zip, png_member, xml_member

#: ORA composite-op -> blend function over floats (backdrop Cb, source Cs).
_BLENDS = {
    "svg:multiply": lambda b, s: b * s,
    "svg:screen": lambda b, s: b + s - b * s,
    "svg:darken": np.minimum,
    "svg:lighten": np.maximum,
    "svg:overlay": lambda b, s: np.where(b <= 0.5, 2 * b * s, 1 - 2 * (1 - b) * (1 - s)),
    "svg:hard-light": lambda b, s: np.where(s <= 0.5, 2 * b * s, 1 - 2 * (1 - b) * (1 - s)),
    "svg:difference": lambda b, s: np.abs(b - s),
    "svg:plus": lambda b, s: np.minimum(b + s, 1.0),
}


def _float(el, key: str, default: float) -> float:
    try:
        v = float(el.get(key, default))
    except ValueError:
        return default
    return v if np.isfinite(v) else default


def _int(el, key: str) -> int:
    try:
        return int(float(el.get(key, 0)))
    except ValueError:
        return 0


def read_ora(path: str) -> LayeredArt:
    """Read an OpenRaster file as layers. Raises ImageError."""
    with open_zip(path, "OpenRaster") as zf:
        root = xml_member(zf, "stack.xml", path)
        if root.tag != "image":
            raise ImageError("stack.xml: the root element is not <image>", file=path)
        w, h = _int(root, "w"), _int(root, "h")
        check_size(w, h, "document", path)
        art = LayeredArt(path, (w, h))
        stack = root.find("stack")
        if stack is None:
            raise ImageError("stack.xml: no <stack>", file=path)
        _Walk(zf, art, path).stack(stack, "", 1.0, 0, 0)
    return art


class _Walk:
    def __init__(self, zf, art: LayeredArt, path: str):
        self.zf, self.art, self.path, self.taken = zf, art, path, set()

    def stack(self, stack, prefix: str, opacity: float, dx: int, dy: int) -> None:
        for el in reversed(list(stack)):  # stack.xml lists the top first
            if el.tag not in ("layer", "stack"):
                continue
            name, tags = split_tags(el.get("name") or el.get("src") or el.tag)
            full = prefix + name
            if "ignore" in tags:
                continue
            if el.get("visibility", "visible") == "hidden":
                self.art.hidden.append(full)
                continue
            alpha = opacity * min(max(_float(el, "opacity", 1.0), 0.0), 1.0)
            x, y = dx + _int(el, "x"), dy + _int(el, "y")
            if el.tag == "stack" and "merge" in tags:
                self.merged(el, full, alpha, x, y)
            elif el.tag == "stack":
                self.stack(el, full + "/", alpha, x, y)
            else:
                self.layer(el, full, alpha, x, y)

    def layer(self, el, name: str, alpha: float, x: int, y: int) -> None:
        src = el.get("src")
        if not src:
            self.art.notes.append(f"{name}: a layer without pixels (no src) skipped")
            return
        rgba = scale_alpha(png_member(self.zf, src, self.path), alpha)
        op = el.get("composite-op", "svg:src-over")
        if op != "svg:src-over":
            self.blend(name, op, rgba, (x, y))
            return
        lay = cropped(unique(name, self.taken), rgba, (x, y))
        if lay is not None:
            self.art.layers.append(lay)

    def blend(self, name: str, op: str, rgba: np.ndarray, offset) -> None:
        from puppet.imaging.layered.blend import bake_down

        func = _BLENDS.get(op)
        if func is None:
            self.art.notes.append(f"{name}: composite-op {op} refused (not supported); layer skipped")
            return
        rest, into = bake_down(self.art.layers, rgba, offset, func)
        kept = "; the rest kept as a normal layer" if rest[..., 3].any() else ""
        self.art.notes.append(f"{name}: composite-op {op} baked into {', '.join(map(repr, into)) or 'nothing'}{kept}")
        lay = cropped(unique(name, self.taken), rest, offset) if rest[..., 3].any() else None
        if lay is not None:
            self.art.layers.append(lay)

    def merged(self, el, name: str, alpha: float, x: int, y: int) -> None:
        inner = LayeredArt(self.path, self.art.size)
        _Walk(self.zf, inner, self.path).stack(el, "", 1.0, x, y)
        self.art.notes.extend(f"{name}/{n}" for n in inner.notes)
        if not inner.layers:
            return
        x0 = min(lay.bounds[0] for lay in inner.layers)
        y0 = min(lay.bounds[1] for lay in inner.layers)
        x1 = max(lay.bounds[2] for lay in inner.layers)
        y1 = max(lay.bounds[3] for lay in inner.layers)
        check_size(x1 - x0, y1 - y0, f"group {name!r}", self.path)
        shifted = [type(lay)(lay.name, lay.rgba, (lay.offset[0] - x0, lay.offset[1] - y0)) for lay in inner.layers]
        rgba = scale_alpha(over(shifted, (x1 - x0, y1 - y0)), alpha)
        lay = cropped(unique(name, self.taken), rgba, (x0, y0))
        if lay is not None:
            self.art.layers.append(lay)
