"""PSD and PSB files read with ``psd-tools`` (imported only here, when such a file is read).

What becomes of each kind of layer (see docs/import.md):

- pixel, type, shape, smart-object and fill layers: their pixels, with the layer's mask,
  vector mask, clipping layers and the effects psd-tools draws baked in (through its
  compositor); a plain pixel layer is read directly (faster, same pixels);
- opacity and fill opacity, and the opacity of enclosing groups: multiplied into alpha;
- a blend mode other than normal: baked into the imported layers below, each pixel into
  the frontmost one that has it (:mod:`puppet.imaging.layered.blend`); what covers none
  stays a layer of its own, drawn normal (over nothing a blend mode draws as normal);
- adjustment layers: baked into the layers below them with psd-tools' adjustment
  functions (:mod:`puppet.imaging.layered.adjust`), or skipped with a note;
- hidden layers and groups: skipped; ``[ignore]``: skipped; ``[merge]`` groups, and
  groups that have clipping layers over them: one layer; a group's pixel mask: applied
  to each of its layers;
- 16-bit documents: rounded to 8 bits; 32-bit (linear light): sRGB-encoded as psd-tools'
  ``topil`` does; CMYK: converted to RGB with the document's colour profile by psd-tools;
  Lab: converted to sRGB (D50 white, Bradford). Duotone and multichannel are refused.
"""
from __future__ import annotations

import os
import struct

import numpy as np

from puppet.errors import ImageError
from puppet.imaging import io as image_io  # the limits, read when used
from puppet.imaging.layered.adjust import adjustment_function, bake_adjustment
from puppet.imaging.layered.art import (ArtLayer, LayeredArt, Totals, add_hidden, apply_mask, check_depth, check_size,
                                        cropped, scale_alpha, split_tags, to_rgba, to_uint8, unique, why)
from puppet.imaging.layered.blend import bake_down, bake_onto

#: Largest PSD/PSB file read: psd-tools reads a whole file into memory (a document within
#: the image limits with many full-size layers stays well below).
MAX_FILE = 2 << 30
#: Colour modes read (PSD header codes): bitmap, grayscale, indexed, RGB, CMYK.
_MODES = {0: "bitmap", 1: "grayscale", 2: "indexed", 3: "RGB", 4: "CMYK", 9: "Lab"}
_OTHER_MODES = {7: "multichannel", 8: "duotone"}
#: XYZ (D50, Photoshop's Lab white) to linear sRGB, Bradford-adapted (Lindbloom's table).
_XYZ50_TO_SRGB = np.array([[3.1338561, -1.6168667, -0.4906146],
                           [-0.9787684, 1.9161415, 0.0334540],
                           [0.0719453, -0.2289914, 1.4052427]], np.float32)
_D50 = np.array([0.96422, 1.0, 0.82521], np.float32)
_PLAIN_KINDS = ("pixel", "type", "shape", "smartobject")


def read_header(path: str) -> tuple[int, int, int, int]:
    """(width, height, depth, colour mode) from a PSD/PSB header, checked: signature,
    version, size limits, supported mode and depth. Raises ImageError."""
    try:
        with open(path, "rb") as f:
            head = f.read(26)
            size = os.fstat(f.fileno()).st_size
    except OSError as e:
        raise ImageError(f"cannot be read ({e.strerror})", file=path) from None
    if size > MAX_FILE:  # psd-tools holds the whole file in memory
        raise ImageError(f"file too large ({size} bytes; at most {MAX_FILE >> 20} MiB)", file=path)
    if len(head) < 26 or head[:4] != b"8BPS":
        raise ImageError("not a Photoshop file (no PSD signature)", file=path)
    version, channels, h, w, depth, mode = struct.unpack(">H6xHIIHH", head[4:26])
    if version not in (1, 2):
        raise ImageError(f"unknown PSD version {version}", file=path)
    check_size(w, h, "document", path)
    if mode not in _MODES:
        name = _OTHER_MODES.get(mode, f"mode {mode}")
        raise ImageError(f"{name} colour mode is not supported; convert the document to RGB", file=path)
    if depth not in (1, 8, 16, 32):
        raise ImageError(f"unsupported bit depth {depth}", file=path)
    return w, h, depth, mode


def read_psd(path: str) -> LayeredArt:
    """Read a PSD/PSB as layers (see the module docstring). Raises ImageError."""
    import logging
    import warnings

    logging.getLogger("psd_tools").setLevel(logging.CRITICAL + 1)  # its chatter must not reach the terminal
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return _read_psd(path)


def _read_psd(path: str) -> LayeredArt:
    w, h, _, _ = read_header(path)
    psd = _open(path, max_alloc=image_io.MAX_PIXELS * 4 * 8)
    art = LayeredArt(path, (w, h))
    reader = _Reader(art, path, psd)
    try:
        _totals(psd, path, (w, h))
        reader.group(psd, "", 1.0)
    except ImageError:
        raise
    except Exception as e:  # psd-tools on a damaged file: any error is "cannot be read"
        raise ImageError(f"corrupt or unsupported layer data ({why(e)})", file=path) from None
    if not art.layers and not reader.seen:
        art.layers.extend(_flat(psd, path, art, reader))
    return art


def _open(path: str, max_alloc: int):
    from psd_tools import PSDImage

    try:
        return PSDImage.open(path, max_alloc_bytes=max_alloc)
    except MemoryError:
        raise ImageError("too large to read", file=path) from None
    except Exception as e:  # truncated or damaged: psd-tools raises many kinds
        raise ImageError(f"corrupt or truncated PSD ({why(e)})", file=path) from None


def _totals(psd, path: str, canvas: tuple[int, int]) -> None:
    """Every layer's box (hidden ones are read too) from the layer records, held to the
    totals before any pixel is decoded (:class:`~puppet.imaging.layered.art.Totals`);
    groups nested too deep refused."""
    totals, todo = Totals(path, canvas), [(psd, 1)]
    while todo:  # iterative: the depth is checked, never recursed into
        group, depth = todo.pop()
        for layer in group:
            if layer.is_group():
                check_depth(depth, layer.name, path)
                todo.append((layer, depth + 1))
                continue
            x0, y0, x1, y1 = layer.bbox
            if x1 > x0 and y1 > y0:
                totals.add(x1 - x0, y1 - y0, f"layer {layer.name[:80]!r}")
    totals.check()


def _flat(psd, path: str, art: LayeredArt, reader) -> list[ArtLayer]:
    """A document without layers: its merged image as one layer."""
    try:
        a = np.atleast_3d(psd.numpy())
        rgba = to_rgba(to_uint8(reader._colour(a, alpha=reader.has_alpha(a))))
    except Exception as e:
        raise ImageError(f"corrupt image data ({why(e)})", file=path) from None
    art.notes.append("the document has no layers: its merged image is one layer")
    lay = cropped("image", rgba, (0, 0))
    return [lay] if lay is not None else []


class _Reader:
    """Walks the layer tree bottom to top, appending to ``art.layers``."""

    def __init__(self, art: LayeredArt, path: str, psd, *, reveal: bool = False):
        self.art, self.path, self.taken, self.seen = art, path, set(), 0
        self.psd, self.reveal = psd, reveal  # reveal: read hidden layers too (inside a hidden group)
        self.depth, self.cmyk = psd.depth, int(psd.color_mode) == 4
        self.lab = int(psd.color_mode) == 9
        self.rgb = not (self.cmyk or self.lab)  # RGB, grey, bitmap, indexed: numpy() gives the colours
        self.icc = _icc(psd) if self.cmyk else None

    def note(self, text: str) -> None:
        self.art.notes.append(text)

    def group(self, group, prefix: str, opacity: float, masks: tuple = (), start: int = 0,
              through: tuple = ()) -> None:
        """Import ``group``'s layers; ``start``: the first imported layer its adjustment
        layers reach (the group's own when it is isolated, else its parent's); ``through``:
        the pass-through groups between it and there, as (first imported layer, the group's
        own opacity, the opacity its layers were given)."""
        for layer in group:  # psd-tools iterates a group bottom to top
            if getattr(layer, "clipping", False):
                continue  # drawn by its base layer's composite
            self.seen += 1
            name, tags = split_tags(layer.name)
            full = prefix + name
            if "ignore" in tags:
                continue
            if not layer.visible and not self.reveal:
                if layer.kind != "adjustment" and not _is_adjustment(layer):
                    inner = _Reader(LayeredArt(self.path, self.art.size), self.path, self.psd, reveal=True)
                    inner.group([layer], prefix, opacity, masks)
                    add_hidden(self.art, self.taken, inner.art, full)
                continue
            alpha = opacity * layer.opacity / 255.0
            if layer.is_group() and "merge" not in tags and layer.has_clip_layers(visible=True):
                self.note(f"{full}: a group with clipping layers over it is imported as one layer")
                self.pixels(layer, full, opacity, masks)
            elif layer.is_group() and "merge" not in tags:
                if layer.has_vector_mask():
                    self.note(f"{full}: the group's vector mask is not applied to its layers")
                if _blend(layer) in ("pass_through", "passthrough"):
                    inner, chain = start, through + ((len(self.art.layers), layer.opacity / 255.0, alpha),)
                else:
                    inner, chain = len(self.art.layers), ()
                self.group(layer, full + "/", alpha, masks + _mask(layer), inner, chain)
            elif layer.kind == "adjustment" or _is_adjustment(layer):
                self.adjust(layer, full, start, through)
            else:
                self.pixels(layer, full, opacity, masks)

    def adjust(self, layer, name: str, start: int, through: tuple) -> None:
        """Bake adjustment ``layer`` into the imported layers from ``start`` on.

        Inside a pass-through group of opacity a the adjustment changes the composite
        below it, and the group's result is mixed with the backdrop at a:
        ``(1 - a) B + a A(B over M)``, B the backdrop, M the group's layers below the
        adjustment (coverage m), A the adjustment. The group's layers (drawn at a already)
        take it in full; a layer below the group takes it at ``a (1 - m) / (1 - a m)`` at
        each pixel, which gives that composite exactly where A is linear over the pixel
        (at the file's own positions): a where nothing of the group covers the layer, 0
        where the group is opaque over it."""
        fn = adjustment_function(layer)
        if fn is None or not self.rgb or self.depth == 32:
            self.note(f"{name}: adjustment layer ({layer.kind}) skipped (not drawn for this kind or document)")
            return
        targets = self.art.layers[start:]  # (hidden ones among them are left as they are)
        strength = []
        for i, lay in enumerate(targets):
            k = 1.0
            for first, a, alpha in through:
                if first > start + i:  # the group does not hold this layer
                    m = self._coverage(first, lay, alpha)
                    k = k * a * (1.0 - m) / np.maximum(1.0 - a * m, 1e-6)
            strength.append(k)
        n = bake_adjustment(layer, fn, targets, _mask(layer), strength)
        self.note(f"{name}: adjustment ({layer.kind}) baked into the {n} layer(s) below it")

    def _coverage(self, first: int, lay: ArtLayer, alpha: float) -> np.ndarray:
        """(h, w, 1) float32 over ``lay``'s pixels: how much the imported layers from
        ``first`` on cover them (the union of their alphas), each alpha divided by
        ``alpha``, the opacity their groups gave them (so a group's own coverage)."""
        h, w = lay.rgba.shape[:2]
        clear = np.ones((h, w, 1), np.float32)
        x0, y0 = lay.offset
        for other in self.art.layers[first:]:
            if not other.visible:
                continue
            ox, oy = other.offset
            oh, ow = other.rgba.shape[:2]
            ax, ay, bx, by = max(x0, ox), max(y0, oy), min(x0 + w, ox + ow), min(y0 + h, oy + oh)
            if ax >= bx or ay >= by:
                continue
            a = other.rgba[ay - oy:by - oy, ax - ox:bx - ox, 3:].astype(np.float32) / (255.0 * max(alpha, 1e-6))
            clear[ay - y0:by - y0, ax - x0:bx - x0] *= 1.0 - np.minimum(a, 1.0)
        return 1.0 - clear

    def pixels(self, layer, name: str, opacity: float, masks: tuple = ()) -> None:
        mode = _blend(layer)
        rgba, offset = self._render(layer, name)
        if rgba is None:
            return
        if layer.is_group() and layer.has_clip_layers(visible=True):
            self._clip_group(layer, rgba, offset)
        scale_alpha(rgba, opacity)
        for mask in masks:
            apply_mask(rgba, offset, *mask)
        if mode not in ("normal", "pass_through", "passthrough") and self.art.layers:
            rgba = self._bake(name, mode, rgba, offset)
        elif mode not in ("normal", "pass_through", "passthrough"):
            self.note(f"{name}: blend mode {mode} over nothing is normal: imported as is")
        lay = cropped(unique(name, self.taken), rgba, offset) if rgba is not None else None
        if lay is not None:
            self.art.layers.append(lay)

    def _clip_group(self, group, rgba: np.ndarray, offset) -> None:
        """Draw the clipping layers over a group into its pixels (psd-tools' group
        composite leaves them out)."""
        from psd_tools.composite.blend import BLEND_FUNC
        from psd_tools.constants import BlendMode

        base = ArtLayer(group.name, rgba, offset)
        for clip in group.clip_layers:
            if not clip.is_visible():
                continue
            c, at = self._raster(clip), clip.bbox[:2]  # (psd-tools composites a clip layer alone as empty)
            func = BLEND_FUNC.get(getattr(BlendMode, _blend(clip).upper(), None), BLEND_FUNC[BlendMode.NORMAL])
            if c is not None:
                bake_onto(base, c, at, func, atop=True)

    def _render(self, layer, name: str):
        """(rgba (h, w, 4) uint8 with the layer's own opacity, offset) or (None, None)."""
        x0, y0, x1, y1 = layer.bbox
        if x1 <= x0 or y1 <= y0:
            return None, None
        check_size(x1 - x0, y1 - y0, f"layer {name!r}", self.path)
        plain = (layer.kind == "pixel" and not layer.has_mask() and not layer.has_vector_mask()
                 and not layer.has_clip_layers() and not layer.has_effects())
        if plain and self.rgb:
            return self._raster(layer), (x0, y0)
        if layer.has_effects():
            self.note(f"{name}: layer effects drawn as psd-tools renders them (some, e.g. shadows "
                      "and glows, may be missing)")
        try:
            return self._composite(layer, (x0, y0, x1, y1))
        except ImportError:  # vector shapes and fills need aggdraw (psd-tools[composite])
            if layer.is_group():
                self.note(f"{name}: group not drawn (its vector shapes need aggdraw); skipped")
                return None, None
            self.note(f"{name}: vector shape or fill not drawn (needs aggdraw): its stored pixels imported")
            return self._raster(layer), (x0, y0)

    def _raster(self, layer) -> np.ndarray | None:
        """The layer's stored pixels with its opacity and fill opacity."""
        a = layer.numpy()
        if a is None:
            return None
        rgba = to_rgba(to_uint8(self._colour(a, alpha=self.has_alpha(a))))
        return scale_alpha(rgba, layer.opacity / 255.0 * layer.fill_opacity / 255.0)

    def has_alpha(self, a: np.ndarray) -> bool:
        """Whether an array from psd-tools' ``numpy()`` ends with an alpha channel."""
        return a.shape[2] == 5 if self.cmyk else a.shape[2] in (2, 4)

    def _colour(self, a: np.ndarray, *, alpha: bool) -> np.ndarray:
        """Floats as the document stores them to sRGB-encoded RGB(A) floats: 32-bit
        documents hold linear light (encoded here as psd-tools' ``topil`` does), CMYK is
        converted with the document's colour profile (psd-tools' own conversion)."""
        if self.cmyk:
            return self._from_cmyk(a, alpha=alpha)
        if self.lab:
            return np.concatenate([srgb_encode(lab_to_linear(a[..., :3])), a[..., 3:4]], axis=2)
        if self.depth == 32:
            c = a.shape[2] - alpha
            a = a.copy()
            a[..., :c] = srgb_encode(a[..., :c])
        return a

    def _from_cmyk(self, a: np.ndarray, *, alpha: bool) -> np.ndarray:
        from PIL import Image
        from psd_tools.api.pil_io import post_process

        im = post_process(Image.fromarray(to_uint8(a[..., :4]), "CMYK"), None, self.icc)
        rgb = np.asarray(im.convert("RGB"), np.float32) / 255.0
        return np.concatenate([rgb, a[..., 4:5]], axis=2) if alpha else rgb

    def _composite(self, layer, box):
        from psd_tools.composite import composite

        W, H = self.art.size
        if layer.has_effects():  # strokes and shadows reach beyond the pixels: the canvas
            box = (min(box[0], 0), min(box[1], 0), max(box[2], W), max(box[3], H))
        check_size(box[2] - box[0], box[3] - box[1], f"layer {layer.name!r}", self.path)
        shown = (lambda _: True) if self.reveal else None  # inside a hidden group: draw it as if shown
        colour, _, alpha = composite(layer, color=0.0, alpha=0.0, viewport=box, force=False, layer_filter=shown)
        a = np.concatenate([np.atleast_3d(colour), np.atleast_3d(alpha)], axis=2)
        rgba = to_rgba(to_uint8(self._colour(a, alpha=True)))
        if layer.is_group():  # a group's own opacity is not in its composite
            scale_alpha(rgba, layer.opacity / 255.0)
        return rgba, (box[0], box[1])

    def _bake(self, name: str, mode: str, rgba: np.ndarray, offset) -> np.ndarray | None:
        """Blend the layer into the imported layers below it, each pixel into the topmost
        one that has it; returns the rest (drawn normal: over nothing), None if none."""
        from psd_tools.composite.blend import BLEND_FUNC
        from psd_tools.constants import BlendMode

        func = BLEND_FUNC.get(getattr(BlendMode, mode.upper(), None))
        if func is None:
            self.note(f"{name}: blend mode {mode} refused (no blend function); layer skipped")
            return None
        rest, into = bake_down(self.art.layers, rgba, offset, func)
        kept = "; the rest kept as a normal layer" if rest[..., 3].any() else ""
        self.note(f"{name}: blend mode {mode} baked into {', '.join(map(repr, into)) or 'nothing'}{kept}")
        return rest if rest[..., 3].any() else None


def srgb_encode(lin: np.ndarray) -> np.ndarray:
    """Linear light in [0, 1] to sRGB-encoded values (IEC 61966-2-1)."""
    lin = np.clip(lin, 0.0, 1.0)
    return np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.power(lin, 1 / 2.4) - 0.055)


def lab_to_linear(lab: np.ndarray) -> np.ndarray:
    """(..., 3) Lab as psd-tools gives it (L/100, (a + 128)/255, (b + 128)/255 in [0, 1])
    to linear sRGB (D50 -> D65 by Bradford)."""
    L = lab[..., 0] * 100.0
    a, b = lab[..., 1] * 255.0 - 128.0, lab[..., 2] * 255.0 - 128.0
    fy = (L + 16.0) / 116.0
    f = np.stack([fy + a / 500.0, fy, fy - b / 200.0], axis=-1)
    d = 6.0 / 29.0
    xyz = np.where(f > d, f ** 3, 3 * d * d * (f - 4.0 / 29.0)) * _D50
    return xyz @ _XYZ50_TO_SRGB.T


def _mask(group) -> tuple:
    """A group's enabled pixel mask as ((h, w) uint8, (x, y), value outside), in a tuple."""
    if not group.has_mask() or group.mask.disabled:
        return ()
    m = group.mask
    img = m.topil()
    x0, y0, _, _ = m.bbox
    inside = np.asarray(img.convert("L"), np.uint8) if img is not None else np.zeros((0, 0), np.uint8)
    return ((inside, (x0, y0), int(m.background_color)),)


def _icc(psd) -> bytes | None:
    from psd_tools.constants import Resource

    res = psd.image_resources
    return res.get_data(Resource.ICC_PROFILE) if Resource.ICC_PROFILE in res else None


def _blend(layer) -> str:
    mode = layer.blend_mode
    return str(getattr(mode, "name", mode)).lower()


def _is_adjustment(layer) -> bool:
    from psd_tools.api.layers import AdjustmentLayer

    return isinstance(layer, AdjustmentLayer)
