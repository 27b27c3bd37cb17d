"""OpenRaster (``.ora``, Krita, GIMP, MyPaint...): a zip of PNG layers and ``stack.xml``.

``stack.xml`` lists layers top first; ``<stack>`` elements are groups. Read: each
``<layer>``'s PNG at its ``x``, ``y``, with its ``opacity`` (times its groups'),
``visibility`` and name; ``composite-op`` other than ``svg:src-over`` is baked into the
layers below with the matching separable blend (multiply, screen, overlay, darken,
lighten, ...; see :mod:`puppet.imaging.layered.blend`), else the layer is skipped
with a note.
"""
from __future__ import annotations

from puppet.errors import ImageError
from puppet.imaging.layered.art import (LayeredArt, Totals, add_hidden, check_depth, check_size, cropped, flatten,
                                        scale_alpha, split_tags, unique)
from puppet.imaging.layered.blend import add_blended, separable
from puppet.imaging.layered.zipped import coordinate, image_size, number, open_zip, png_member, xml_member

#: The document's largest side accepted in ``stack.xml`` (larger is refused by the image limits).
_MAX_DOC = 1 << 30


def read_ora(path: str) -> LayeredArt:
    """Read an OpenRaster file as layers. Raises ImageError."""
    with open_zip(path, "OpenRaster") as zf:
        root = xml_member(zf, "stack.xml", path)
        if root.tag != "image":
            raise ImageError("stack.xml: the root element is not <image>", file=path)
        w, h = (int(number(root, k, path, "stack.xml: <image>", default=0, lo=0, hi=_MAX_DOC, whole=True))
                for k in ("w", "h"))
        check_size(w, h, "document", path)
        art = LayeredArt(path, (w, h))
        stack = root.find("stack")
        if stack is None:
            raise ImageError("stack.xml: no <stack>", file=path)
        totals = Totals(path, (w, h))
        for el, name in _read(stack, "", path):  # every size from the PNG headers before any pixel
            totals.add(*image_size(zf, el.get("src"), path), f"layer {name[:80]!r}")
        totals.check()
        _Walk(zf, art, path).stack(stack, "", 1.0, 0, 0)
    return art


def _shown(el, prefix: str):
    """``(full name, tags)`` of a layer or group that is read, hidden ones too; None when
    it is skipped (ignored)."""
    name, tags = split_tags(el.get("name") or el.get("src") or el.tag)
    if "ignore" in tags:
        return None
    return prefix + name, tags


def _read(stack, prefix: str, path: str, depth: int = 1):
    """``(element, full name)`` of every ``<layer>`` with pixels that is read (groups
    nested deeper than :data:`~puppet.imaging.layered.art.MAX_DEPTH` refused)."""
    for el in stack:
        shown = el.tag in ("layer", "stack") and _shown(el, prefix)
        if not shown:
            continue
        if el.tag == "stack":
            check_depth(depth, shown[0], path)
            yield from _read(el, shown[0] + "/", path, depth + 1)
        elif el.get("src"):
            yield el, shown[0]


class _Walk:
    def __init__(self, zf, art: LayeredArt, path: str, *, reveal: bool = False):
        self.zf, self.art, self.path, self.taken = zf, art, path, set()
        self.reveal = reveal  # read hidden elements too (inside a hidden stack)

    def stack(self, stack, prefix: str, opacity: float, dx: int, dy: int) -> None:
        for el in reversed(list(stack)):  # stack.xml lists the top first
            if el.tag not in ("layer", "stack"):
                continue
            name, tags = split_tags(el.get("name") or el.get("src") or el.tag)
            full = prefix + name
            if "ignore" in tags:
                continue
            if el.get("visibility", "visible") == "hidden" and not self.reveal:
                inner = _Walk(self.zf, LayeredArt(self.path, self.art.size), self.path, reveal=True)
                inner.stack([el], prefix, opacity, dx, dy)
                add_hidden(self.art, self.taken, inner.art, full)
                continue
            where = f"stack.xml: {el.tag} {full[:80]!r}"
            alpha = opacity * number(el, "opacity", self.path, where, default=1.0, lo=0.0, hi=1.0, clamp=True)
            x = dx + coordinate(el, "x", self.path, where)
            y = dy + coordinate(el, "y", self.path, where)
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
