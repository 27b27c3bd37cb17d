"""Bounded reading of zip-based art files (ORA, KRA): members, XML and PNGs.

A member is read only when its declared size is within a limit, and reading stops one
byte past the limit whatever the header says (a zip bomb or a lying header is refused
with one line, never decompressed to the end).
"""
from __future__ import annotations

import codecs
import io
import lzma
import math
import re
import zipfile
import zlib

import numpy as np

from puppet.errors import ImageError
from puppet.imaging import io as image_io  # the limits, read when used
from puppet.imaging.decode import pillow_to_rgba
from puppet.imaging.layered.art import check_size, why

#: Largest XML member (stack.xml, maindoc.xml).
MAX_XML = 16 << 20
#: Largest layer coordinate (x, y) accepted, in pixels either way.
MAX_COORD = 1 << 20
#: What reading a damaged member can raise (zlib, lzma and bz2 data errors included).
_READ_ERRORS = (zipfile.BadZipFile, EOFError, OSError, ValueError, NotImplementedError, RuntimeError,
                zlib.error, lzma.LZMAError)
_DECLARED = re.compile(rb"""^<\?xml[^>]*?encoding\s*=\s*["']([A-Za-z0-9._:-]{1,40})["']""")
_BOMS = [(codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"), (codecs.BOM_UTF8, "utf-8-sig"),
         (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"),
         (b"<\0\0\0", "utf-32-le"), (b"\0\0\0<", "utf-32-be"), (b"<\0", "utf-16-le"), (b"\0<", "utf-16-be")]


def open_zip(path: str, kind: str) -> zipfile.ZipFile:
    """The zip archive at ``path``; ImageError when it is not one."""
    try:
        return zipfile.ZipFile(path)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as e:
        raise ImageError(f"not a readable {kind} file (not a zip archive: {why(e)})", file=path) from None


def info_of(zf: zipfile.ZipFile, name: str, path: str, *, required: bool = True) -> zipfile.ZipInfo | None:
    """Member ``name``'s entry (None when absent and not ``required``); an encrypted
    member is refused."""
    try:
        info = zf.getinfo(name)
    except KeyError:
        if required:
            raise ImageError(f"the archive has no {name[:200]!r}", file=path) from None
        return None
    if info.flag_bits & 0x1:
        raise ImageError(f"{name[:200]}: encrypted (password-protected members are not read)", file=path)
    return info


def member(zf: zipfile.ZipFile, name: str, limit: int, path: str, *, required: bool = True) -> bytes | None:
    """The bytes of member ``name`` (None when absent and not ``required``)."""
    info = info_of(zf, name, path, required=required)
    if info is None:
        return None
    if info.file_size > limit:
        raise ImageError(f"{name}: too large ({info.file_size} bytes; at most {limit})", file=path)
    try:
        with zf.open(info) as f:
            data = f.read(limit + 1)
    except _READ_ERRORS as e:
        raise ImageError(f"{name}: cannot be read ({why(e)})", file=path) from None
    if len(data) > limit:
        raise ImageError(f"{name}: larger than its header says (more than {limit} bytes)", file=path)
    return data


def xml_member(zf: zipfile.ZipFile, name: str, path: str):
    """The parsed XML root of member ``name``."""
    import xml.etree.ElementTree as ET

    text = xml_text(member(zf, name, MAX_XML, path), name, path)
    if "<!ENTITY" in text:
        raise ImageError(f"{name}: XML entity declarations are not accepted", file=path)
    try:
        return ET.fromstring(text)  # the text checked is the text parsed
    except (ET.ParseError, ValueError, LookupError) as e:
        raise ImageError(f"{name}: not valid XML ({why(e)})", file=path) from None


def xml_text(data: bytes, name: str, path: str) -> str:
    """An XML document's bytes decoded as its parser would: by its byte order mark, else
    the byte pattern of ``<`` (UTF-16/32 without a mark), else its declaration's
    ``encoding``, else UTF-8. ImageError when they do not decode."""
    codec = next((c for mark, c in _BOMS if data.startswith(mark)), None)
    if codec is None:
        m = _DECLARED.match(data)
        codec = m.group(1).decode("ascii") if m else "utf-8"
    try:
        return data.decode(codec)
    except LookupError:
        raise ImageError(f"{name}: unknown XML encoding {codec!r}", file=path) from None
    except UnicodeError as e:
        raise ImageError(f"{name}: not valid {codec} text ({why(e)})", file=path) from None


def number(el, key: str, path: str, where: str, *, default: float, lo: float, hi: float,
           whole: bool = False, clamp: bool = False) -> float:
    """The XML attribute ``key`` of ``el`` as a number (``default`` when absent or empty),
    refused in one line naming ``where``, the attribute and its text when it is not a
    finite number in [``lo``, ``hi``] (or not ``whole`` when asked); ``clamp``: a finite
    number outside is brought into the range instead."""
    raw = el.get(key)
    if raw is None or not raw.strip():
        return default
    try:
        v = float(raw)
    except ValueError:
        v = math.nan
    if clamp and math.isfinite(v):
        v = min(max(v, lo), hi)
    if not (math.isfinite(v) and lo <= v <= hi) or (whole and v != int(v)):
        kind = "a whole number" if whole else "a number"
        raise ImageError(f"{where}: {key}={raw[:40]!r} is not {kind} from {lo:.12g} to {hi:.12g}", file=path)
    return v


def coordinate(el, key: str, path: str, where: str) -> int:
    """A layer's ``x`` or ``y`` (pixels, within :data:`MAX_COORD`), rounded down."""
    return math.floor(number(el, key, path, where, default=0.0, lo=-MAX_COORD, hi=MAX_COORD))


def image_size(zf: zipfile.ZipFile, name: str, path: str) -> tuple[int, int]:
    """The (w, h) of image member ``name`` from its header alone (nothing decoded)."""
    from PIL import Image

    info = info_of(zf, name, path)
    try:
        with zf.open(info) as f, Image.open(f) as im:
            return im.size
    except Exception as e:  # Pillow or zipfile on damaged data: any error is "cannot be read"
        raise ImageError(f"{name[:200]}: not a readable image ({why(e)})", file=path) from None


def png_member(zf: zipfile.ZipFile, name: str, path: str) -> np.ndarray:
    """Member ``name`` decoded as (h, w, 4) uint8 RGBA, its size checked from the header
    before any pixel is decoded."""
    from PIL import Image

    data = member(zf, name, image_io.MAX_PIXELS * 8 + (16 << 20), path)
    try:
        im = Image.open(io.BytesIO(data))
        check_size(*im.size, name, path)
        im.load()
        return pillow_to_rgba(im)[0]
    except ImageError:
        raise
    except Exception as e:  # Pillow on damaged data: any error is "cannot be read"
        raise ImageError(f"{name}: not a readable image ({why(e)})", file=path) from None
