"""PSD and PSB files read with ``psd-tools`` (imported only here, when such a file is read).

What becomes of each kind of layer (see docs/import.md):

- pixel, type, shape, smart-object and fill layers: their pixels, with the layer's mask,
  vector mask, clipping layers and the effects psd-tools draws baked in (through its
  compositor); a plain pixel layer is read directly (faster, same pixels);
- opacity and fill opacity, and the opacity of enclosing groups: multiplied into alpha;
- a blend mode other than normal: baked into the imported layer just below (clipped to
  it, as a clipping mask would be), or skipped with a note when there is none below;
- adjustment layers: skipped with a note (they change every layer below them);
- hidden layers and groups: skipped; ``[ignore]``: skipped; ``[merge]`` groups: one layer.
"""
from __future__ import annotations

import struct

import numpy as np

from puppet.errors import ImageError
from puppet.imaging.layered import (ArtLayer, LayeredArt, check_size, cropped, scale_alpha, split_tags,
                                    to_rgba, to_uint8, unique)

#: Colour modes read (PSD header codes): bitmap, grayscale, indexed, RGB.
_MODES = {0: "bitmap", 1: "grayscale", 2: "indexed", 3: "RGB"}
_OTHER_MODES = {4: "CMYK", 7: "multichannel", 8: "duotone", 9: "Lab"}
_PLAIN_KINDS = ("pixel", "type", "shape", "smartobject")


def read_header(path: str) -> tuple[int, int, int, int]:
    """(width, height, depth, colour mode) from a PSD/PSB header, checked: signature,
    version, size limits, supported mode and depth. Raises ImageError."""
    try:
        with open(path, "rb") as f:
            head = f.read(26)
    except OSError as e:
        raise ImageError(f"cannot be read ({e.strerror})", file=path) from None
    if len(head) < 26 or head[:4] != b"8BPS":
        raise ImageError("not a Photoshop file (no PSD signature)", file=path)
    version, channels, h, w, depth, mode = struct.unpack(">H6xHIIHH", head[4:26])
    if version not in (1, 2):
        raise ImageError(f"unknown PSD version {version}", file=path)
    check_size(w, h, "document", path)
    if mode not in _MODES:
        name = _OTHER_MODES.get(mode, f"mode {mode}")
        raise ImageError(f"{name} colour mode is not supported; convert the document to RGB", file=path)
    if depth == 32:
        raise ImageError("32-bit (HDR) documents are not supported; convert to 8 or 16 bits", file=path)
    if depth not in (1, 8, 16):
        raise ImageError(f"unsupported bit depth {depth}", file=path)
    return w, h, depth, mode


def read_psd(path: str) -> LayeredArt:
    """Read a PSD/PSB as layers (see the module docstring). Raises ImageError."""
    from puppet.imaging.io import MAX_PIXELS

    w, h, _, _ = read_header(path)
    psd = _open(path, max_alloc=MAX_PIXELS * 4 * 8)
    art = LayeredArt(path, (w, h))
    reader = _Reader(art, path)
    try:
        reader.group(psd, "", 1.0)
    except ImageError:
        raise
    except Exception as e:  # psd-tools on a damaged file: any error is "cannot be read"
        raise ImageError(f"corrupt or unsupported layer data ({type(e).__name__}: {e})", file=path) from None
    if not art.layers and not art.hidden and not reader.seen:
        art.layers.extend(_flat(psd, path, art))
    return art


def _open(path: str, max_alloc: int):
    import logging

    from psd_tools import PSDImage

    logging.getLogger("psd_tools").setLevel(logging.ERROR)  # its warnings must not reach the terminal
    try:
        return PSDImage.open(path, max_alloc_bytes=max_alloc)
    except MemoryError:
        raise ImageError("too large to read", file=path) from None
    except Exception as e:  # truncated or damaged: psd-tools raises many kinds
        raise ImageError(f"corrupt or truncated PSD ({type(e).__name__}: {e})", file=path) from None


def _flat(psd, path: str, art: LayeredArt) -> list[ArtLayer]:
    """A document without layers: its merged image as one layer."""
    try:
        rgba = to_rgba(to_uint8(psd.numpy()))
    except Exception as e:
        raise ImageError(f"corrupt image data ({type(e).__name__}: {e})", file=path) from None
    art.notes.append("the document has no layers: its merged image is one layer")
    lay = cropped("image", rgba, (0, 0))
    return [lay] if lay is not None else []


class _Reader:
    """Walks the layer tree bottom to top, appending to ``art.layers``."""

    def __init__(self, art: LayeredArt, path: str):
        self.art, self.path, self.taken, self.seen = art, path, set(), 0

    def note(self, text: str) -> None:
        self.art.notes.append(text)

    def group(self, group, prefix: str, opacity: float) -> None:
        for layer in group:  # psd-tools iterates a group bottom to top
            if getattr(layer, "clipping", False):
                continue  # drawn by its base layer's composite
            self.seen += 1
            name, tags = split_tags(layer.name)
            full = prefix + name
            if "ignore" in tags:
                continue
            if not layer.visible:
                self.art.hidden.append(full)
                continue
            alpha = opacity * layer.opacity / 255.0
            if layer.is_group() and "merge" not in tags:
                if layer.has_mask():
                    self.note(f"{full}: the group's mask is not applied to its layers")
                self.group(layer, full + "/", alpha)
            elif layer.kind == "adjustment" or _is_adjustment(layer):
                self.note(f"{full}: adjustment layer skipped (it would change every layer below it)")
            else:
                self.pixels(layer, full, opacity)

    def pixels(self, layer, name: str, opacity: float) -> None:
        mode = _blend(layer)
        rgba, offset = self._render(layer, name)
        if rgba is None:
            return
        scale_alpha(rgba, opacity)
        if mode not in ("normal", "pass_through", "passthrough"):
            self._bake(name, mode, rgba, offset)
            return
        lay = cropped(unique(name, self.taken), rgba, offset)
        if lay is not None:
            self.art.layers.append(lay)

    def _render(self, layer, name: str):
        """(rgba (h, w, 4) uint8 with the layer's own opacity, offset) or (None, None)."""
        x0, y0, x1, y1 = layer.bbox
        if x1 <= x0 or y1 <= y0:
            return None, None
        check_size(x1 - x0, y1 - y0, f"layer {name!r}", self.path)
        plain = (layer.kind == "pixel" and not layer.has_mask() and not layer.has_vector_mask()
                 and not layer.has_clip_layers() and not layer.has_effects())
        if plain:
            a = layer.numpy()
            if a is None:
                return None, None
            rgba = to_rgba(to_uint8(a))
            return scale_alpha(rgba, layer.opacity / 255.0 * layer.fill_opacity / 255.0), (x0, y0)
        if layer.has_effects():
            self.note(f"{name}: layer effects drawn as psd-tools renders them (some, e.g. shadows "
                      "and glows, may be missing)")
        return self._composite(layer, (x0, y0, x1, y1))

    def _composite(self, layer, box):
        from psd_tools.composite import composite

        W, H = self.art.size
        if layer.has_effects():  # strokes and shadows reach beyond the pixels: the canvas
            box = (min(box[0], 0), min(box[1], 0), max(box[2], W), max(box[3], H))
        check_size(box[2] - box[0], box[3] - box[1], f"layer {layer.name!r}", self.path)
        colour, _, alpha = composite(layer, color=0.0, alpha=0.0, viewport=box, force=False)
        a = np.concatenate([np.atleast_3d(colour), np.atleast_3d(alpha)], axis=2)
        rgba = to_rgba(to_uint8(a))
        if layer.is_group():  # a group's own opacity is not in its composite
            scale_alpha(rgba, layer.opacity / 255.0)
        return rgba, (box[0], box[1])

    def _bake(self, name: str, mode: str, rgba: np.ndarray, offset) -> None:
        from psd_tools.composite.blend import BLEND_FUNC
        from psd_tools.constants import BlendMode

        func = BLEND_FUNC.get(getattr(BlendMode, mode.upper(), None))
        below = self.art.layers[-1] if self.art.layers else None
        if func is None or below is None:
            why = "no blend function" if func is None else "no layer below"
            self.note(f"{name}: blend mode {mode} refused ({why}); layer skipped")
            return
        bake_onto(below, rgba, offset, func)
        self.note(f"{name}: blend mode {mode} baked into {below.name!r} (clipped to it)")


def _blend(layer) -> str:
    mode = layer.blend_mode
    return str(getattr(mode, "name", mode)).lower()


def _is_adjustment(layer) -> bool:
    from psd_tools.api.layers import AdjustmentLayer

    return isinstance(layer, AdjustmentLayer)


def bake_onto(below: ArtLayer, rgba: np.ndarray, offset, func) -> None:
    """Blend ``rgba`` at ``offset`` into ``below`` with ``func(Cb, Cs)`` (floats in [0, 1],
    (h, w, 3)), inside ``below``'s pixels only: C = (1 - a_s) Cb + a_s B(Cb, Cs); the
    alpha of ``below`` is unchanged."""
    bx0, by0, bx1, by1 = below.bounds
    sx0, sy0 = offset
    sx1, sy1 = sx0 + rgba.shape[1], sy0 + rgba.shape[0]
    x0, y0, x1, y1 = max(bx0, sx0), max(by0, sy0), min(bx1, sx1), min(by1, sy1)
    if x0 >= x1 or y0 >= y1:
        return
    dst = below.rgba[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0]
    src = rgba[y0 - sy0:y1 - sy0, x0 - sx0:x1 - sx0].astype(np.float32) / 255.0
    cb = dst[..., :3].astype(np.float32) / 255.0
    a = src[..., 3:]
    mixed = (1 - a) * cb + a * np.asarray(func(cb, src[..., :3]), np.float32)
    dst[..., :3] = to_uint8(mixed)
