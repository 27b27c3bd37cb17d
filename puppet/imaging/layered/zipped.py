"""Bounded reading of zip-based art files (ORA, KRA): members, XML and PNGs.

A member is read only when its declared size is within a limit, and reading stops one
byte past the limit whatever the header says (a zip bomb or a lying header is refused
with one line, never decompressed to the end).
"""
from __future__ import annotations

import io
import zipfile

import numpy as np

from puppet.errors import ImageError
from puppet.imaging import io as image_io  # the limits, read when used
from puppet.imaging.decode import pillow_to_rgba
from puppet.imaging.layered.art import check_size, why

#: Largest XML member (stack.xml, maindoc.xml).
MAX_XML = 16 << 20


def open_zip(path: str, kind: str) -> zipfile.ZipFile:
    """The zip archive at ``path``; ImageError when it is not one."""
    try:
        return zipfile.ZipFile(path)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as e:
        raise ImageError(f"not a readable {kind} file (not a zip archive: {why(e)})", file=path) from None


def member(zf: zipfile.ZipFile, name: str, limit: int, path: str, *, required: bool = True) -> bytes | None:
    """The bytes of member ``name`` (None when absent and not ``required``)."""
    try:
        info = zf.getinfo(name)
    except KeyError:
        if required:
            raise ImageError(f"the archive has no {name!r}", file=path) from None
        return None
    if info.file_size > limit:
        raise ImageError(f"{name}: too large ({info.file_size} bytes; at most {limit})", file=path)
    try:
        with zf.open(info) as f:
            data = f.read(limit + 1)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, NotImplementedError) as e:
        raise ImageError(f"{name}: cannot be read ({why(e)})", file=path) from None
    if len(data) > limit:
        raise ImageError(f"{name}: larger than its header says (more than {limit} bytes)", file=path)
    return data


def xml_member(zf: zipfile.ZipFile, name: str, path: str):
    """The parsed XML root of member ``name``."""
    import xml.etree.ElementTree as ET

    data = member(zf, name, MAX_XML, path)
    if b"<!ENTITY" in data:
        raise ImageError(f"{name}: XML entity declarations are not accepted", file=path)
    try:
        return ET.fromstring(data)
    except ET.ParseError as e:
        raise ImageError(f"{name}: not valid XML ({why(e)})", file=path) from None


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
