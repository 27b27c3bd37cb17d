"""Image loading with limits (writing lives in :mod:`puppet.output`, re-exported here).

Every image a user names goes through :func:`decode_image` (:func:`load_rgba`,
:func:`load_mask_image`), which refuses missing, non-regular (FIFO, device), corrupt,
non-image and absurdly large files (decompression bombs) with an :class:`ImageError`
naming the file, before any pixel is decoded, and converts every pixel format to 8-bit
RGBA as the image looks (:mod:`puppet.imaging.decode`).
"""
from __future__ import annotations

import contextlib
import os
import stat
import struct
import sys
import tempfile
import threading
import warnings

import numpy as np

from puppet.errors import ImageError
from puppet.imaging.decode import array_to_rgba, luma, orient, pillow_to_rgba
from puppet.output import atomic_write, save_png  # noqa: F401  (re-exported: one output mechanism)

#: Largest side we accept: the GL texture limit we can count on everywhere.
MAX_SIDE = 16384
#: Largest pixel count we decode (64 megapixels, 256 MiB as RGBA).
MAX_PIXELS = 64 * 1024 * 1024


def _fail_for(path: str, scene_file: str | None, json_path: str | None):
    def fail(msg: str) -> ImageError:
        return ImageError(f"image {path!r}: {msg}", file=scene_file, path=json_path)
    return fail


def _check_stat(st: os.stat_result, fail) -> None:
    if stat.S_ISDIR(st.st_mode):
        raise fail("is a folder, not an image")
    if not stat.S_ISREG(st.st_mode):
        raise fail("is not a regular file (a FIFO, device or socket cannot be an image)")
    if st.st_size == 0:  # also what /proc and other pseudo files say of themselves
        raise fail("is empty (0 bytes; a file under /proc is not an image either)")


def _check_size(w: int, h: int, fail) -> None:
    if w < 1 or h < 1:
        raise fail(f"empty image ({w}x{h})")
    if w > MAX_SIDE or h > MAX_SIDE or w * h > MAX_PIXELS:
        raise fail(f"too large ({w}x{h}; at most {MAX_SIDE} per side and {MAX_PIXELS} pixels)")


def _open_regular(path: str, fail):
    """An unbuffered-safe binary file object on a regular file; never blocks (a FIFO or
    device is refused by ``stat`` before opening and by ``fstat`` after)."""
    try:
        _check_stat(os.stat(path), fail)
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise fail("no such file") from None
    except OSError as e:
        raise fail(f"cannot be read ({e.strerror})") from None
    except ValueError:  # os.stat: "embedded null byte"
        raise fail("not a valid file name (it holds a NUL byte)") from None
    try:
        _check_stat(os.fstat(fd), fail)
    except BaseException:
        os.close(fd)
        raise
    return os.fdopen(fd, "rb")


def _probe(f, fail):
    """Open an image from its header: (Pillow image or None for a TIFF only OpenCV
    reads, (width, height) as stored, EXIF orientation). Sizes are checked."""
    from PIL import Image, UnidentifiedImageError

    try:
        im = Image.open(f)
    except UnidentifiedImageError:
        f.seek(0)
        if f.read(4) in (b"II*\x00", b"MM\x00*"):  # float colour TIFFs: Pillow has no mode for them
            size = _tiff_size(f, fail)
            _check_size(*size, fail)
            return None, size, 1
        raise fail("not an image file (PNG, JPEG, ... expected)") from None
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise fail(f"too large (more than {MAX_PIXELS} pixels)") from None
    except (OSError, ValueError, SyntaxError, EOFError) as e:
        raise fail(f"cannot be read ({e})") from None
    _check_size(*im.size, fail)
    try:
        orientation = int(im.getexif().get(0x0112, 1))
    except Exception:  # a broken EXIF block only loses the orientation
        orientation = 1
    return im, im.size, orientation


@contextlib.contextmanager
def _opened(path: str, scene_file: str | None, json_path: str | None):
    from PIL import Image

    fail = _fail_for(path, scene_file, json_path)
    with _open_regular(path, fail) as f, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # decoder chatter must not reach the user's terminal
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        yield (f, fail) + _probe(f, fail)


def image_size(path: str, *, scene_file: str | None = None, json_path: str | None = None) -> tuple[int, int]:
    """(width, height) of an image as :func:`decode_image` returns it (EXIF orientation
    applied), from the header alone. Raises ImageError like :func:`decode_image`."""
    with _opened(path, scene_file, json_path) as (_, _, _, (w, h), orientation):
        return (h, w) if orientation in (5, 6, 7, 8) else (w, h)


def decode_image(path: str, *, scene_file: str | None = None,
                 json_path: str | None = None) -> tuple[np.ndarray, bool]:
    """Read an image file as 8-bit RGBA, as it looks (see :mod:`puppet.imaging.decode`).

    Returns
    -------
    rgba : (h, w, 4) uint8, straight alpha, EXIF orientation applied.
    has_alpha : whether the file has an alpha channel or a transparent colour.

    Raises
    ------
    ImageError
        Missing, not a regular file, not an image, corrupt or too large (checked from
        the header, before any pixel is decoded).
    """
    fail = _fail_for(path, scene_file, json_path)
    try:
        return _decode(path, scene_file, json_path, fail)
    except OSError as e:  # reading failed under the decoder (EIO, a file shrinking, ...)
        raise fail(f"cannot be read ({e.strerror or e})") from None


def _decode(path: str, scene_file, json_path, fail) -> tuple[np.ndarray, bool]:
    with _open_regular(path, fail) as f:
        plain = _plain_png(f)
    if plain is not None:
        return plain
    with _opened(path, scene_file, json_path) as (f, fail, im, size, orientation):
        try:
            if im is None or _wide_colour(im, f):  # 16-bit colour: Pillow would keep only the high byte
                return _decode_with_opencv(f, size, orientation, fail)
            with _c_stderr_captured(im.format == "TIFF") as said:
                try:
                    im.load()
                    rgba, has_alpha = pillow_to_rgba(im)
                except (OSError, ValueError, SyntaxError, EOFError, struct.error) as e:
                    error = e
                else:
                    error = None
            if error is not None:
                detail = f"{error}: {said[0]}" if said and said[0] else str(error)
                raise fail(f"corrupt or truncated ({detail})") from None
        except ImageError:
            raise
        except (OSError, ValueError, SyntaxError, EOFError, struct.error) as e:
            raise fail(f"corrupt or truncated ({e})") from None
    return np.ascontiguousarray(orient(rgba, orientation)), has_alpha


#: PNG chunks read by OpenCV as Pillow reads them: the palette and the transparency key
#: (applied by both; not to grey, see below), and chunks that do not touch the pixels. No
#: colour-profile, gamma or chromaticity chunks: libpng prints warnings about those on the
#: terminal ("known incorrect sRGB profile"); text or eXIf may hold an orientation. Files
#: with any other chunk are read by Pillow.
_PLAIN_CHUNKS = {b"IHDR": None, b"PLTE": None, b"tRNS": None, b"IDAT": None, b"IEND": 0, b"pHYs": 9,
                 b"tIME": 7, b"sRGB": 1}  # kind: its length when fixed
#: (colour type, bit depth) of the PNGs read by OpenCV: grey, RGB, grey + alpha, RGBA in 8
#: bits; palettes in 1 to 8 bits; 1-bit grey.
_PLAIN_FORMATS = frozenset({(0, 8), (2, 8), (4, 8), (6, 8), (3, 1), (3, 2), (3, 4), (3, 8), (0, 1)})


def _plain_chunks(data: bytes, colour: int) -> bool:
    """Every chunk of the PNG ``data`` is one of :data:`_PLAIN_CHUNKS` with a valid length
    and CRC, up to IEND; a transparency key only for RGB (6 bytes) or a palette (at most one
    entry per colour); an sRGB intent 0-3."""
    import zlib

    i, view, palette = 8, memoryview(data), 0
    while i + 12 <= len(data):
        n = int.from_bytes(data[i:i + 4], "big")
        kind = data[i + 4:i + 8]
        end = i + 8 + n
        if kind not in _PLAIN_CHUNKS or _PLAIN_CHUNKS[kind] not in (None, n) or end + 4 > len(data) \
                or zlib.crc32(view[i + 4:end]) != int.from_bytes(data[end:end + 4], "big"):
            return False
        if kind == b"PLTE":
            palette = n // 3
        elif kind == b"tRNS" and not ((colour == 2 and n == 6) or (colour == 3 and 0 < n <= palette)):
            return False
        elif kind == b"sRGB" and data[i + 8] > 3:
            return False
        elif kind == b"IEND":
            return True
        i = end + 4
    return False  # truncated before IEND


def _plain_png(f) -> tuple[np.ndarray, bool] | None:
    """A PNG of :data:`_PLAIN_FORMATS` with only :data:`_PLAIN_CHUNKS`, intact (every
    chunk's CRC checked, IEND present), decoded by OpenCV: the pixels and transparency
    Pillow gives (tested on every bundled PNG and each format), in a third of its time and
    without importing Pillow (~20 ms of a command's start). None for any other file, whose
    every check and message is then the Pillow path's."""
    head = f.read(33)
    if len(head) < 33 or head[:16] != b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR":
        return None
    w, h, depth, colour = struct.unpack(">IIBB", head[16:26])
    if (colour, depth) not in _PLAIN_FORMATS or not (0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE and w * h <= MAX_PIXELS):
        return None
    f.seek(0, os.SEEK_END)
    if f.tell() > w * h * 8 + (16 << 20):  # far more than any encoding of these pixels
        return None
    f.seek(0)
    data = f.read()
    if not _plain_chunks(data, colour):
        return None
    import cv2

    a = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if a is None or a.dtype != np.uint8 or a.shape[:2] != (h, w):
        return None
    return array_to_rgba(a)


_STDERR_LOCK = threading.Lock()


@contextlib.contextmanager
def _c_stderr_captured(active: bool):
    """While decoding, send what C libraries write to file descriptor 2 (libtiff's
    messages, which Pillow does not silence) to a temporary file instead of the user's
    terminal; yields a list that receives the first line written."""
    said: list[str] = []
    if not active:
        yield said
        return
    with _STDERR_LOCK, tempfile.TemporaryFile() as tmp:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(tmp.fileno(), 2)
        try:
            yield said
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            said.append(tmp.read(4096).decode("utf-8", "replace").strip().split("\n")[0][:200])


def _wide_colour(im, f) -> bool:
    """A 16-bit-per-sample colour or grey+alpha PNG or TIFF."""
    if im.mode not in ("RGB", "RGBA", "LA"):
        return False
    if im.format == "PNG":
        f.seek(24)
        return f.read(1) == b"\x10"  # IHDR bit depth
    if im.format == "TIFF":
        bits = im.tag_v2.get(258, (8,))
        return max(bits if isinstance(bits, tuple) else (bits,)) == 16
    return False


def _tiff_size(f, fail) -> tuple[int, int]:
    """Width and height from the first directory of a classic TIFF."""
    f.seek(0)
    head = f.read(8)
    bo = "<" if head[:2] == b"II" else ">"
    try:
        f.seek(struct.unpack(bo + "I", head[4:8])[0])
        n = struct.unpack(bo + "H", f.read(2))[0]
        size = {}
        for _ in range(min(n, 4096)):
            tag, typ, _count, value = struct.unpack(bo + "HHI4s", f.read(12))
            if tag in (256, 257):
                size[tag] = struct.unpack(bo + ("H" if typ == 3 else "I"), value[:2 if typ == 3 else 4])[0]
    except struct.error:
        raise fail("corrupt or truncated TIFF header") from None
    if len(size) != 2:
        raise fail("not an image file (TIFF without a size)")
    return size[256], size[257]


def _decode_with_opencv(f, size: tuple[int, int], orientation: int, fail) -> tuple[np.ndarray, bool]:
    import cv2

    w, h = size
    _check_size(w, h, fail)
    f.seek(0, os.SEEK_END)
    n = f.tell()
    if n > w * h * 4 * 8 + (16 << 20):  # more than raw 64-bit RGBA plus metadata: not this image
        raise fail(f"file too large for a {w}x{h} image ({n} bytes)")
    f.seek(0)
    data = np.frombuffer(f.read(), np.uint8)
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # the error below says it all
    try:
        a = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    finally:
        cv2.utils.logging.setLogLevel(level)
    if a is None:
        raise fail("corrupt or truncated (the decoder gave no pixels)")
    if a.shape[:2] != (h, w):
        raise fail(f"corrupt (header says {w}x{h}, pixels are {a.shape[1]}x{a.shape[0]})")
    try:
        rgba, has_alpha = array_to_rgba(a)
    except ValueError as e:
        raise fail(str(e)) from None
    return np.ascontiguousarray(orient(rgba, orientation)), has_alpha


def load_rgba(path: str, *, scene_file: str | None = None, json_path: str | None = None) -> np.ndarray:
    """Read an image file as RGBA (see :func:`decode_image`).

    Returns
    -------
    (h, w, 4) uint8 array, straight alpha.

    Raises
    ------
    ImageError
        Missing, unreadable, corrupt or too large file; the message names ``path`` and,
        when given, the scene file and JSON path that referred to it.
    """
    return decode_image(path, scene_file=scene_file, json_path=json_path)[0]


def load_mask_image(path: str, *, scene_file: str | None = None, json_path: str | None = None) -> np.ndarray:
    """Read a mask file: alpha > 0 when it has alpha, else non-zero grey (as Pillow's
    ``convert("L")`` computes it from the 8-bit colour) is object.

    Returns
    -------
    (h, w) bool array.
    """
    rgba, has_alpha = decode_image(path, scene_file=scene_file, json_path=json_path)
    return rgba[..., 3] > 0 if has_alpha else luma(rgba) > 0
