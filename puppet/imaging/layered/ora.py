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
from puppet.imaging.layered.art import LayeredArt, check_size, cropped, flatten, scale_alpha, split_tags, unique
from puppet.imaging.layered.blend import add_blended, separable
from puppet.imaging.layered.zipped import open_zip, png_member, xml_member

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
            add_blended(self.art, self.taken, name, op, separable(op), rgba, (x, y))
            return
        lay = cropped(unique(name, self.taken), rgba, (x, y))
        if lay is not None:
            self.art.layers.append(lay)

    def merged(self, el, name: str, alpha: float, x: int, y: int) -> None:
        inner = LayeredArt(self.path, self.art.size)
        _Walk(self.zf, inner, self.path).stack(el, "", 1.0, x, y)
        self.art.notes.extend(f"{name}/{n}" for n in inner.notes)
        lay = flatten(unique(name, self.taken), inner.layers, alpha, self.path)
        if lay is not None:
            self.art.layers.append(lay)
