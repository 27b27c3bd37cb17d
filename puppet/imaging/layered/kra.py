"""Krita documents (``.kra``): a zip with ``maindoc.xml`` (the layer tree), one tile file
per paint layer and ``mergedimage.png`` (the composite).

Paint layers in 8-bit RGBA are read from their tiles: a text header (``VERSION 2``,
``TILEWIDTH``, ``TILEHEIGHT``, ``PIXELSIZE``, ``DATA n``) then ``n`` tiles, each a line
``x,y,LZF,size`` and ``size`` bytes: a flag and the tile's pixels, BGRA: flag 1, LZF
over the pixels stored plane by plane (every pixel's first byte, then every second
byte...); flag 0, the pixels raw, one after the other (as Krita's KisTileCompressor2).

Group layers give names ``group/layer`` (``[merge]``, ``[ignore]`` as in PSD); the
separable blend modes (multiply, screen, overlay, ...) are baked as in ORA; other kinds (filter, fill, vector, clone, file layers, masks) are skipped with a note. A
document none of whose layers can be read this way (another colour depth or model) is
imported as its merged image, one layer, with a note.
"""
from __future__ import annotations

import numpy as np

from puppet.errors import ImageError
from puppet.imaging import io as image_io  # the limits, read when used
from puppet.imaging.layered.art import (LayeredArt, Totals, add_hidden, check_depth, check_size, cropped,
                                        flatten, scale_alpha, split_tags, unique, why)
from puppet.imaging.layered.blend import add_blended, separable
from puppet.imaging.layered.zipped import coordinate, member, number, open_zip, png_member, xml_member

#: Most LZF tokens (literal runs and back-references) one import decodes: the decoder is
#: pure Python, about 1-4 us a token, so this bounds the time to tens of seconds. A tile
#: repeated in the file (same bytes) is decoded once.
MAX_LZF_TOKENS = 8_000_000
#: Decoded tiles kept for reuse (by their bytes), at most.
_CACHE_TILES = 4096
#: Bytes of tile files kept from sizing the layers to decoding them (not read twice).
_KEEP_FILES = 256 << 20
#: The document's largest side accepted in maindoc.xml (larger is refused by the image limits).
_MAX_DOC = 1 << 30


def lzf_decompress(data: bytes, size: int) -> bytes:
    """Decompress LZF (liblzf's format) to exactly ``size`` bytes (ValueError otherwise).

    Each control byte c < 32 starts c + 1 literal bytes; else a back-reference of length
    (c >> 5) + 2 (an extra length byte when c >> 5 == 7) at distance ((c & 31) << 8) + next + 1.
    """
    return lzf_tokens(data, size)[0]


def lzf_tokens(data: bytes, size: int) -> tuple[bytes, int]:
    """:func:`lzf_decompress`, and how many tokens it decoded (its work)."""
    out = bytearray()
    i, n, tokens = 0, len(data), 0
    while i < n:
        tokens += 1
        c = data[i]
        i += 1
        if c < 32:
            out += data[i:i + c + 1]
            i += c + 1
        else:
            length = c >> 5
            if length == 7:
                length += data[i]
                i += 1
            if i >= n:
                raise ValueError("truncated back-reference")
            ref = len(out) - ((c & 31) << 8) - data[i] - 1
            i += 1
            length += 2
            if ref < 0:
                raise ValueError("back-reference before the start")
            dist = len(out) - ref
            if dist >= length:
                out += out[ref:ref + length]
            else:
                chunk = out[ref:]
                out += (chunk * (length // dist + 1))[:length]
        if len(out) > size:
            break
    if len(out) != size:
        raise ValueError(f"decompressed to {len(out)} bytes, expected {size}")
    return bytes(out), tokens


def _header(data: bytes) -> tuple[dict, int]:
    """The tile file's header values and where the tiles start."""
    values, pos = {}, 0
    for _ in range(5):
        end = data.index(b"\n", pos)
        key, _, value = data[pos:end].decode("ascii").partition(" ")
        values[key] = int(value) if key != "VERSION" else value
        pos = end + 1
    return values, pos


class TileIndex:
    """A paint layer's tile file, its tiles located but not decoded: tile size ``tw`` x
    ``th``, ``tiles`` as (x, y, start, end) of each tile's bytes in the file, and the
    box they cover (``x0``, ``y0``, ``w``, ``h``; w = 0 when there are none)."""

    def __init__(self, data: bytes, name: str, path: str):
        try:
            head, pos = _header(data)
            tw, th, px, count = head["TILEWIDTH"], head["TILEHEIGHT"], head["PIXELSIZE"], head["DATA"]
        except (ValueError, KeyError, UnicodeDecodeError):
            raise ImageError(f"layer {name[:80]!r}: not a Krita tile file", file=path) from None
        if px != 4 or not (0 < tw <= 1024 and 0 < th <= 1024):
            raise ImageError(f"layer {name[:80]!r}: {px}-byte pixels or {tw}x{th} tiles are not read", file=path)
        if not 0 <= count <= len(data) // 8:  # a tile takes a line of at least 8 bytes
            raise ImageError(f"layer {name[:80]!r}: {count} tiles in a file of {len(data)} bytes", file=path)
        self.tw, self.th, self.tiles = tw, th, []
        try:
            for _ in range(count):
                end = data.index(b"\n", pos, pos + 64)
                x, y, _, size = data[pos:end].decode("ascii").split(",")
                x, y, size, pos = int(x), int(y), int(size), end + 1
                if not (abs(x) <= image_io.MAX_SIDE * 64 and abs(y) <= image_io.MAX_SIDE * 64 and 0 < size
                        and pos + size <= len(data)):
                    raise ValueError(f"tile at {x},{y} of {size} bytes")
                self.tiles.append((x, y, pos, pos + size))
                pos += size
        except (ValueError, UnicodeDecodeError) as e:
            raise ImageError(f"layer {name[:80]!r}: corrupt tile data ({why(e)})", file=path) from None
        if self.tiles:
            self.x0, self.y0 = min(t[0] for t in self.tiles), min(t[1] for t in self.tiles)
            self.w = max(t[0] for t in self.tiles) + tw - self.x0
            self.h = max(t[1] for t in self.tiles) + th - self.y0
        else:
            self.x0 = self.y0 = self.w = self.h = 0


class Tiles:
    """Tiles decoded for one import: decoded tiles kept by their bytes (a tile repeated
    is decoded once) and the work done, held to :data:`MAX_LZF_TOKENS`; ``files``: tile
    files read while sizing the layers, kept for decoding (up to :data:`_KEEP_FILES`)."""

    def __init__(self, path: str):
        self.path, self.cache, self.tokens, self.files = path, {}, 0, {}

    def decode(self, data: bytes, index: TileIndex, offset: tuple[int, int], name: str):
        """The layer's pixels (h, w, 4) uint8 and the (x, y) of its top-left (``offset``:
        the layer's x, y in maindoc.xml), or (None, None) without tiles."""
        if not index.tiles:
            return None, None
        tw, th, n = index.tw, index.th, index.tw * index.th * 4
        out = np.zeros((index.h, index.w, 4), np.uint8)
        for x, y, start, end in index.tiles:
            blob = data[start:end]
            bgra = self.cache.get(blob)
            if bgra is None:
                bgra = self._tile(blob, n, tw, th, name)
                if len(self.cache) < _CACHE_TILES:
                    self.cache[blob] = bgra
            out[y - index.y0:y - index.y0 + th, x - index.x0:x - index.x0 + tw] = bgra
        return out, (index.x0 + offset[0], index.y0 + offset[1])

    def _tile(self, blob: bytes, n: int, tw: int, th: int, name: str) -> np.ndarray:
        """One tile as (th, tw, 4) RGBA."""
        try:
            if blob[:1] == b"\x01":  # LZF over the planes: every B, then every G, R, A
                raw, tokens = lzf_tokens(blob[1:], n)
                self.tokens += tokens
                bgra = np.frombuffer(raw, np.uint8).reshape(4, th, tw).transpose(1, 2, 0)
            else:  # raw: the tile's pixels as they are, BGRA
                if len(blob) != n + 1:
                    raise ValueError("short raw tile")
                bgra = np.frombuffer(blob[1:], np.uint8).reshape(th, tw, 4)
        except (ValueError, IndexError) as e:
            raise ImageError(f"layer {name[:80]!r}: corrupt tile data ({why(e)})", file=self.path) from None
        if self.tokens > MAX_LZF_TOKENS:
            raise ImageError(f"decode work: more than the limit of {MAX_LZF_TOKENS} LZF tokens in all "
                             f"(at layer {name[:80]!r})", file=self.path)
        return np.ascontiguousarray(bgra[..., [2, 1, 0, 3]])


def read_tiles(data: bytes, offset: tuple[int, int], name: str, path: str):
    """A paint layer's tile file as (rgba (h, w, 4) uint8, (x, y) of its top-left), or
    (None, None) without tiles; ``offset`` is the layer's x, y in maindoc.xml."""
    return Tiles(path).decode(data, TileIndex(data, name, path), offset, name)


def read_kra(path: str) -> LayeredArt:
    """Read a Krita document as layers. Raises ImageError."""
    with open_zip(path, "Krita") as zf:
        root = xml_member(zf, "maindoc.xml", path)
        image = root.find("IMAGE")
        if image is None:
            raise ImageError("maindoc.xml: no <IMAGE>", file=path)
        w, h = (int(number(image, k, path, "maindoc.xml: <IMAGE>", default=0, lo=0, hi=_MAX_DOC, whole=True))
                for k in ("width", "height"))
        check_size(w, h, "document", path)
        art = LayeredArt(path, (w, h))
        walk = _Walk(zf, art, path, image.get("name", ""), Tiles(path))
        layers = image.find("layers")
        if layers is not None:
            walk.plan(layers, (w, h))
            walk.layers(layers, "", 1.0)
        if not any(lay.visible for lay in art.layers):
            rgba = png_member(zf, "mergedimage.png", path)
            art.notes.append("no layer could be read (only 8-bit RGBA paint layers are): "
                             "the merged image is one layer")
            lay = cropped("image", rgba, (0, 0))
            art.layers.extend([lay] if lay is not None else [])
    return art


def _shown(node, prefix: str):
    """``(full name, tags)`` of a layer that is read, hidden ones too (None: ignored)."""
    name, tags = split_tags(node.get("name") or "layer")
    if "ignore" in tags:
        return None
    return prefix + name, tags


def _readable(node) -> bool:
    return node.get("nodetype", "") == "paintlayer" and node.get("colorspacename", "RGBA") == "RGBA"


class _Walk:
    def __init__(self, zf, art: LayeredArt, path: str, doc: str, tiles: Tiles, *, reveal: bool = False):
        self.zf, self.art, self.path, self.doc, self.taken = zf, art, path, doc, set()
        self.tiles, self.reveal = tiles, reveal  # reveal: read hidden layers too (inside a hidden group)
        self.unread = 0  # visible layers of a kind or colour space not read

    def tile_file(self, node, name: str) -> bytes:
        key = f"{self.doc}/layers/{node.get('filename')}"
        kept = self.tiles.files
        if key in kept:
            return kept[key]
        data = member(self.zf, key, image_io.MAX_PIXELS * 6 + (16 << 20), self.path)
        if sum(map(len, kept.values())) + len(data) <= _KEEP_FILES:
            kept[key] = data
        return data

    def plan(self, el, canvas: tuple[int, int]) -> None:
        """Every paint layer read, sized from its tile list before any tile is decoded:
        the totals (:class:`~puppet.imaging.layered.art.Totals`) and the tiles to decode
        (at most :data:`~puppet.imaging.layered.art.MAX_TOTAL_PIXELS` of tile pixels)."""
        totals, boxes = Totals(self.path, canvas), {}
        for node, full in self._read(el, "", 1):
            key = node.get("filename")
            if key not in boxes:
                index = TileIndex(self.tile_file(node, full), full, self.path)
                boxes[key] = (index.w, index.h, len(index.tiles) * index.tw * index.th)
            w, h, px = boxes[key]
            totals.work += px
            if w:
                totals.add(w, h, f"layer {full[:80]!r}")
        totals.check()

    def _read(self, el, prefix: str, depth: int):
        """``(node, full name)`` of every paint layer that is read."""
        for node in el.findall("layer"):
            shown = _shown(node, prefix)
            if shown is None:
                continue
            inner = node.find("layers")
            if node.get("nodetype", "") == "grouplayer" and inner is not None:
                check_depth(depth, shown[0], self.path)
                yield from self._read(inner, shown[0] + "/", depth + 1)
            elif _readable(node):
                yield node, shown[0]

    def layers(self, el, prefix: str, opacity: float, nodes=None) -> None:
        """Read the layers of ``el`` (or the ``nodes`` given, listed top first)."""
        for node in reversed(list(el.findall("layer") if nodes is None else nodes)):  # top first in maindoc.xml
            name, tags = split_tags(node.get("name") or "layer")
            full, kind = prefix + name, node.get("nodetype", "")
            if "ignore" in tags:
                continue
            if node.get("visible", "1") == "0" and not self.reveal:
                inner = _Walk(self.zf, LayeredArt(self.path, self.art.size), self.path, self.doc, self.tiles,
                              reveal=True)
                inner.layers(None, prefix, opacity, [node])
                self.unread += inner.unread
                add_hidden(self.art, self.taken, inner.art, full)
                continue
            where = f"maindoc.xml: layer {full[:80]!r}"
            alpha = opacity * number(node, "opacity", self.path, where, default=255, lo=0, hi=255, whole=True) / 255
            if kind == "grouplayer" and node.find("layers") is not None and "merge" in tags:
                self.merged(node.find("layers"), full, alpha)
                continue
            if kind == "grouplayer" and node.find("layers") is not None:
                self.layers(node.find("layers"), full + "/", alpha)
                continue
            if not _readable(node):
                self.art.notes.append(f"{full}: {kind or 'layer'} ({node.get('colorspacename', '?')}) skipped")
                self.unread += 1
                continue
            xy = (coordinate(node, "x", self.path, where), coordinate(node, "y", self.path, where))
            data = self.tile_file(node, full)
            rgba, offset = self.tiles.decode(data, TileIndex(data, full, self.path), xy, full)
            if rgba is not None:
                self.add(full, node.get("compositeop", "normal"), scale_alpha(rgba, alpha), offset)

    def add(self, name: str, op: str, rgba: np.ndarray, offset) -> None:
        if op not in ("normal", "svg:src-over"):
            add_blended(self.art, self.taken, name, op, separable(op), rgba, offset)
            return
        lay = cropped(unique(name, self.taken), rgba, offset)
        if lay is not None:
            self.art.layers.append(lay)

    def merged(self, el, name: str, alpha: float) -> None:
        inner = _Walk(self.zf, LayeredArt(self.path, self.art.size), self.path, self.doc, self.tiles)
        inner.layers(el, "", 1.0)
        self.art.notes.extend(f"{name}/{n}" for n in inner.art.notes)
        self.unread += inner.unread
        lay = flatten(unique(name, self.taken), inner.art.layers, alpha, self.path)
        if lay is not None:
            self.art.layers.append(lay)
