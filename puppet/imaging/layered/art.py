"""The layers read from an art file (:class:`ArtLayer`, :class:`LayeredArt`) and the
helpers every reader shares: size and file checks, layer names, pixel conversions,
cropping and normal-blend compositing."""
from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass, field

import numpy as np

from puppet.errors import ImageError
from puppet.imaging import io as image_io  # the limits, read when used

_TAG = re.compile(r"\s*\[(merge|ignore)\]\s*", re.IGNORECASE)

#: Most layers read from one file: Photoshop's own limit (8000 layers per document).
MAX_LAYERS = 8000
#: Most pixels one import decodes: the canvas plus every layer read, each counted at the
#: size its header gives (2 GiB as 8-bit RGBA; a 4000x4000 canvas with 32 full-size
#: layers, or 8192x8192 with 7).
MAX_TOTAL_PIXELS = 1 << 29
#: Deepest nesting of groups read (a deeper file is refused in one line).
MAX_DEPTH = 256


@dataclass
class ArtLayer:
    """One layer: ``rgba`` (h, w, 4) uint8 straight alpha, its top-left at ``offset`` (x, y);
    ``visible`` False for a layer the file hides (kept hidden: nothing is baked into it)."""

    name: str
    rgba: np.ndarray
    offset: tuple[int, int]
    visible: bool = True

    @property
    def bounds(self) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1) on the canvas."""
        h, w = self.rgba.shape[:2]
        return self.offset[0], self.offset[1], self.offset[0] + w, self.offset[1] + h


@dataclass
class LayeredArt:
    """A layered document: canvas ``size`` (w, h), ``layers`` back to front, ``notes``
    (one line each: what was baked, skipped or refused), ``hidden`` the names of the hidden
    layers and groups (their layers are among ``layers``, not visible)."""

    path: str
    size: tuple[int, int]
    layers: list[ArtLayer] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    hidden: list[str] = field(default_factory=list)


def why(e: BaseException) -> str:
    """An exception from a reader library as a short single line: ``Type: first line``."""
    text = (str(e).strip().splitlines() or [""])[0][:200]
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


def check_regular(path: str) -> None:
    """Refuse a missing file, a folder, a FIFO or a device (never opened, never blocks)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise ImageError("no such file", file=path) from None
    except OSError as e:
        raise ImageError(f"cannot be read ({e.strerror})", file=path) from None
    if not stat.S_ISREG(st.st_mode):
        raise ImageError("not a regular file", file=path)


def check_size(w: int, h: int, what: str, path: str) -> None:
    """Refuse a document or layer larger than the image limits (before decoding it)."""
    if w < 1 or h < 1:
        raise ImageError(f"{what}: empty ({w}x{h})", file=path)
    side, pixels = image_io.MAX_SIDE, image_io.MAX_PIXELS
    if w > side or h > side or w * h > pixels:
        raise ImageError(f"{what}: too large ({w}x{h}; at most {side} per side and {pixels} pixels)", file=path)


def check_depth(depth: int, name: str, path: str) -> None:
    """Refuse groups nested deeper than :data:`MAX_DEPTH` (``name``: the innermost)."""
    if depth > MAX_DEPTH:
        raise ImageError(f"groups nested more than {MAX_DEPTH} deep (at {name[:80]!r}...)", file=path)


def _mpx(n: int) -> str:
    return f"{n / 1e9:.1f} Gpx" if n >= 1e9 else f"{n / 1e6:.1f} Mpx"


class Totals:
    """What a reader is about to decode, counted from headers before any pixel of it is
    decoded and held to :data:`MAX_LAYERS` and :data:`MAX_TOTAL_PIXELS` (the canvas
    counts too): :meth:`add` each layer, then :meth:`check` before decoding. ``work``:
    pixels of tiles to decode (a tiled format may list a tile more than once), held to
    :data:`MAX_TOTAL_PIXELS` too."""

    def __init__(self, path: str, canvas: tuple[int, int]):
        self.path, self.canvas, self.work = path, canvas, 0
        self.sizes: list[tuple[int, int]] = []

    def add(self, w: int, h: int, what: str) -> None:
        """One layer of ``w`` x ``h`` to decode (checked against the one-image limits)."""
        check_size(w, h, what, self.path)
        self.sizes.append((w, h))

    @property
    def pixels(self) -> int:
        return self.canvas[0] * self.canvas[1] + sum(w * h for w, h in self.sizes)

    def check(self) -> None:
        """Refuse too many layers or pixels in all, in one line naming the limit."""
        n, limit = len(self.sizes), MAX_TOTAL_PIXELS
        if n > MAX_LAYERS:
            raise ImageError(f"{n} layers, more than the limit of {MAX_LAYERS} layers", file=self.path)
        if self.pixels > limit:
            same = len(set(self.sizes)) == 1
            big = max(self.sizes, key=lambda s: s[0] * s[1])
            of = f"{big[0]}x{big[1]}" if same else f"up to {big[0]}x{big[1]}"
            raise ImageError(f"{n} layers of {of} on a {self.canvas[0]}x{self.canvas[1]} canvas = "
                             f"{_mpx(self.pixels)} in all, more than the limit of {_mpx(limit)} "
                             f"({limit} pixels)", file=self.path)
        if self.work > limit:
            raise ImageError(f"tiles of {_mpx(self.work)} to decode in all, more than the limit of "
                             f"{_mpx(limit)} ({limit} pixels)", file=self.path)


def split_tags(name: str) -> tuple[str, set[str]]:
    """A layer name without its ``[merge]`` / ``[ignore]`` tags, and the tags (lower case)."""
    tags = {m.lower() for m in _TAG.findall(name)}
    clean = _TAG.sub(" ", name).strip().replace("/", "_")
    return clean or "layer", tags


def unique(name: str, taken: set[str]) -> str:
    """``name``, or ``name-2``, ``name-3``... the first not in ``taken`` (which it joins)."""
    out, i = name, 1
    while out in taken:
        i += 1
        out = f"{name}-{i}"
    taken.add(out)
    return out


def add_hidden(art: LayeredArt, taken: set[str], inner: LayeredArt, name: str) -> None:
    """Append the layers of a hidden layer or group, read on their own into ``inner`` (so
    that nothing visible bakes into them nor they into it), to ``art``: not visible, named
    apart from ``taken``; ``name`` recorded in ``art.hidden``."""
    art.hidden.append(name)
    for lay in inner.layers:
        art.layers.append(ArtLayer(unique(lay.name, taken), lay.rgba, lay.offset, visible=False))
    art.notes.extend(inner.notes)


def to_uint8(a: np.ndarray) -> np.ndarray:
    """Floats in [0, 1] (or uint8/uint16) to uint8."""
    if a.dtype == np.uint8:
        return a
    if a.dtype == np.uint16:
        return ((a.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    return np.clip(np.rint(np.asarray(a, np.float32) * 255.0), 0, 255).astype(np.uint8)


def to_rgba(a: np.ndarray) -> np.ndarray:
    """(h, w), (h, w, 1|2|3|4) uint8 -> (h, w, 4) uint8 (grey replicated, opaque when no alpha)."""
    if a.ndim == 2:
        a = a[..., None]
    c = a.shape[2]
    colour = a[..., :1].repeat(3, axis=2) if c in (1, 2) else a[..., :3]
    alpha = a[..., -1:] if c in (2, 4) else np.full(a.shape[:2] + (1,), 255, np.uint8)
    return np.ascontiguousarray(np.concatenate([colour, alpha], axis=2))


def scale_alpha(rgba: np.ndarray, opacity: float) -> np.ndarray:
    """``rgba`` with its alpha multiplied by ``opacity`` in [0, 1] (in place when < 1)."""
    if opacity < 1.0:
        rgba[..., 3] = np.rint(rgba[..., 3] * np.float32(opacity)).astype(np.uint8)
    return rgba


def apply_mask(rgba: np.ndarray, offset, mask: np.ndarray, at, outside: int) -> None:
    """Multiply the alpha of ``rgba`` (at ``offset``) by a mask: ``mask`` (values 0-255)
    placed at ``at``, ``outside`` everywhere else."""
    h, w = rgba.shape[:2]
    factor = np.full((h, w), outside, np.float32)
    x0, y0 = at[0] - offset[0], at[1] - offset[1]
    cx0, cy0 = max(x0, 0), max(y0, 0)
    cx1, cy1 = min(x0 + mask.shape[1], w), min(y0 + mask.shape[0], h)
    if cx0 < cx1 and cy0 < cy1:
        factor[cy0:cy1, cx0:cx1] = mask[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]
    rgba[..., 3] = np.rint(rgba[..., 3] * (factor / 255.0)).astype(np.uint8)


def cropped(name: str, rgba: np.ndarray, offset: tuple[int, int]) -> ArtLayer | None:
    """The layer cropped to its pixels with alpha > 0 (None when it has none)."""
    alpha = rgba[..., 3]
    rows = np.flatnonzero(alpha.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(alpha.any(axis=0))
    y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    return ArtLayer(name, np.ascontiguousarray(rgba[y0:y1, x0:x1]), (int(offset[0] + x0), int(offset[1] + y0)))


def flatten(name: str, layers: list[ArtLayer], opacity: float, path: str) -> ArtLayer | None:
    """``layers`` composited into one layer named ``name`` (a ``[merge]`` group), with
    ``opacity``; None when they have no pixels. The group's box is checked against the
    image limits."""
    if not layers:
        return None
    x0, y0 = min(lay.bounds[0] for lay in layers), min(lay.bounds[1] for lay in layers)
    x1, y1 = max(lay.bounds[2] for lay in layers), max(lay.bounds[3] for lay in layers)
    check_size(x1 - x0, y1 - y0, f"group {name!r}", path)
    shifted = [ArtLayer(lay.name, lay.rgba, (lay.offset[0] - x0, lay.offset[1] - y0)) for lay in layers]
    return cropped(name, scale_alpha(over(shifted, (x1 - x0, y1 - y0)), opacity), (x0, y0))


def over(layers: list[ArtLayer], size: tuple[int, int]) -> np.ndarray:
    """Layers composited back to front with normal blending on a transparent canvas of
    ``size`` (w, h): (h, w, 4) straight-alpha uint8."""
    w, h = size
    acc = np.zeros((h, w, 4), np.float32)
    for lay in layers:
        x0, y0, x1, y1 = lay.bounds
        cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        if cx0 >= cx1 or cy0 >= cy1:
            continue
        src = lay.rgba[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0].astype(np.float32) / 255.0
        a = src[..., 3:]
        dst = acc[cy0:cy1, cx0:cx1]
        dst[..., :3] = src[..., :3] * a + dst[..., :3] * (1 - a)
        dst[..., 3:] = a + dst[..., 3:] * (1 - a)
    out = acc.copy()
    np.divide(out[..., :3], out[..., 3:], out=out[..., :3], where=out[..., 3:] > 0)
    return to_uint8(out)
