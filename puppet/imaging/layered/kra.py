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
from puppet.imaging.layered.art import LayeredArt, check_size, cropped, flatten, scale_alpha, split_tags, unique, why
from puppet.imaging.layered.blend import add_blended, separable
from puppet.imaging.layered.zipped import member, open_zip, png_member, xml_member


def lzf_decompress(data: bytes, size: int) -> bytes:
    """Decompress LZF (liblzf's format) to exactly ``size`` bytes (ValueError otherwise).

    Each control byte c < 32 starts c + 1 literal bytes; else a back-reference of length
    (c >> 5) + 2 (an extra length byte when c >> 5 == 7) at distance ((c & 31) << 8) + next + 1.
    """
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
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
    return bytes(out)


def _header(data: bytes) -> tuple[dict, int]:
    """The tile file's header values and where the tiles start."""
    values, pos = {}, 0
    for _ in range(5):
        end = data.index(b"\n", pos)
        key, _, value = data[pos:end].decode("ascii").partition(" ")
        values[key] = int(value) if key != "VERSION" else value
        pos = end + 1
    return values, pos


def read_tiles(data: bytes, offset: tuple[int, int], name: str, path: str):
    """A paint layer's tile file as (rgba (h, w, 4) uint8, (x, y) of its top-left).

    ``offset`` is the layer's x, y in maindoc.xml (added to the tiles' positions)."""
    try:
        head, pos = _header(data)
        tw, th, px, count = head["TILEWIDTH"], head["TILEHEIGHT"], head["PIXELSIZE"], head["DATA"]
    except (ValueError, KeyError, UnicodeDecodeError):
        raise ImageError(f"layer {name!r}: not a Krita tile file", file=path) from None
    if px != 4 or not (0 < tw <= 1024 and 0 < th <= 1024):
        raise ImageError(f"layer {name!r}: {px}-byte pixels or {tw}x{th} tiles are not read", file=path)
    tiles = []
    for _ in range(count):
        end = data.index(b"\n", pos)
        x, y, _, size = data[pos:end].decode("ascii").split(",")
        pos = end + 1
        tiles.append((int(x), int(y), data[pos:pos + int(size)]))
        pos += int(size)
    if not tiles:
        return None, None
    x0, y0 = min(t[0] for t in tiles), min(t[1] for t in tiles)
    x1, y1 = max(t[0] for t in tiles) + tw, max(t[1] for t in tiles) + th
    check_size(x1 - x0, y1 - y0, f"layer {name!r}", path)
    out = np.zeros((y1 - y0, x1 - x0, 4), np.uint8)
    n = tw * th * px
    for x, y, blob in tiles:
        if blob[:1] == b"\x01":  # LZF over the planes: every B, then every G, R, A
            planes = np.frombuffer(lzf_decompress(blob[1:], n), np.uint8).reshape(px, th, tw)
            bgra = planes.transpose(1, 2, 0)
        else:  # raw: the tile's pixels as they are, BGRA
            if len(blob) != n + 1:
                raise ValueError("short raw tile")
            bgra = np.frombuffer(blob[1:], np.uint8).reshape(th, tw, px)
        out[y - y0:y - y0 + th, x - x0:x - x0 + tw] = bgra[..., [2, 1, 0, 3]]
    return out, (x0 + offset[0], y0 + offset[1])


def read_kra(path: str) -> LayeredArt:
    """Read a Krita document as layers. Raises ImageError."""
    with open_zip(path, "Krita") as zf:
        root = xml_member(zf, "maindoc.xml", path)
        image = root.find("IMAGE")
        if image is None:
            raise ImageError("maindoc.xml: no <IMAGE>", file=path)
        try:
            w, h = int(image.get("width", 0)), int(image.get("height", 0))
        except ValueError:
            raise ImageError("maindoc.xml: the image size is not a number", file=path) from None
        check_size(w, h, "document", path)
        art = LayeredArt(path, (w, h))
        walk = _Walk(zf, art, path, image.get("name", ""))
        layers = image.find("layers")
        if layers is not None:
            walk.layers(layers, "", 1.0)
        if not art.layers and (walk.unread or not art.hidden):
            rgba = png_member(zf, "mergedimage.png", path)
            art.notes.append("no layer could be read (only 8-bit RGBA paint layers are): "
                             "the merged image is one layer")
            lay = cropped("image", rgba, (0, 0))
            art.layers.extend([lay] if lay is not None else [])
    return art


class _Walk:
    def __init__(self, zf, art: LayeredArt, path: str, doc: str):
        self.zf, self.art, self.path, self.doc, self.taken = zf, art, path, doc, set()
        self.unread = 0  # visible layers of a kind or colour space not read

    def layers(self, el, prefix: str, opacity: float) -> None:
        for node in reversed(list(el.findall("layer"))):  # maindoc.xml lists the top first
            name, tags = split_tags(node.get("name") or "layer")
            full, kind = prefix + name, node.get("nodetype", "")
            if "ignore" in tags:
                continue
            if node.get("visible", "1") == "0":
                self.art.hidden.append(full)
                continue
            alpha = opacity * min(max(int(node.get("opacity", "255") or 255), 0), 255) / 255.0
            if kind == "grouplayer" and node.find("layers") is not None and "merge" in tags:
                self.merged(node.find("layers"), full, alpha)
                continue
            if kind == "grouplayer" and node.find("layers") is not None:
                self.layers(node.find("layers"), full + "/", alpha)
                continue
            if kind != "paintlayer" or node.get("colorspacename", "RGBA") != "RGBA":
                self.art.notes.append(f"{full}: {kind or 'layer'} ({node.get('colorspacename', '?')}) skipped")
                self.unread += 1
                continue
            limit = image_io.MAX_PIXELS * 6 + (16 << 20)
            data = member(self.zf, f"{self.doc}/layers/{node.get('filename')}", limit, self.path)
            try:
                xy = (int(node.get("x", 0)), int(node.get("y", 0)))
                rgba, offset = read_tiles(data, xy, full, self.path)
            except (ValueError, IndexError) as e:
                raise ImageError(f"layer {full!r}: corrupt tile data ({why(e)})", file=self.path) from None
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
        inner = _Walk(self.zf, LayeredArt(self.path, self.art.size), self.path, self.doc)
        inner.layers(el, "", 1.0)
        self.art.notes.extend(f"{name}/{n}" for n in inner.art.notes)
        self.unread += inner.unread
        lay = flatten(unique(name, self.taken), inner.art.layers, alpha, self.path)
        if lay is not None:
            self.art.layers.append(lay)
