"""Image loading with limits, and atomic image writing.

Every image a user names goes through :func:`load_rgba`, which refuses missing, corrupt,
non-image and absurdly large files (decompression bombs) with an :class:`ImageError`
naming the file, before any pixel is decoded.
"""
from __future__ import annotations

import os
import tempfile
import warnings

import numpy as np

from puppet.errors import ImageError

#: Largest side we accept: the GL texture limit we can count on everywhere.
MAX_SIDE = 16384
#: Largest pixel count we decode (64 megapixels, 256 MiB as RGBA).
MAX_PIXELS = 64 * 1024 * 1024


def _open(path: str, *, scene_file: str | None, json_path: str | None):
    from PIL import Image, UnidentifiedImageError

    def fail(msg: str) -> ImageError:
        return ImageError(f"image {path!r}: {msg}", file=scene_file, path=json_path)

    if not os.path.exists(path):
        raise fail("no such file")
    if os.path.isdir(path):
        raise fail("is a folder, not an image")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            im = Image.open(path)
    except UnidentifiedImageError:
        raise fail("not an image file (PNG, JPEG, ... expected)") from None
    except Image.DecompressionBombError as e:
        raise fail(f"too large ({e})") from None
    except Image.DecompressionBombWarning:
        raise fail(f"too large (more than {MAX_PIXELS} pixels)") from None
    except OSError as e:
        raise fail(f"cannot be read ({e})") from None
    w, h = im.size
    if w < 1 or h < 1:
        raise fail(f"empty image ({w}x{h})")
    if w > MAX_SIDE or h > MAX_SIDE or w * h > MAX_PIXELS:
        raise fail(f"too large ({w}x{h}; at most {MAX_SIDE} per side and {MAX_PIXELS} pixels)")
    return im, fail


def load_rgba(path: str, *, scene_file: str | None = None, json_path: str | None = None) -> np.ndarray:
    """Read an image file as RGBA.

    Returns
    -------
    (h, w, 4) uint8 array, straight alpha.

    Raises
    ------
    ImageError
        Missing, unreadable, corrupt or too large file; the message names ``path`` and,
        when given, the scene file and JSON path that referred to it.
    """
    im, fail = _open(path, scene_file=scene_file, json_path=json_path)
    try:
        with im:
            im.load()
            return np.array(im.convert("RGBA"))
    except (OSError, ValueError, SyntaxError) as e:
        raise fail(f"corrupt or truncated ({e})") from None


def load_mask_image(path: str, *, scene_file: str | None = None, json_path: str | None = None) -> np.ndarray:
    """Read a mask file: alpha > 0 when it has alpha, else non-zero grey is object.

    Returns
    -------
    (h, w) bool array.
    """
    im, fail = _open(path, scene_file=scene_file, json_path=json_path)
    try:
        with im:
            im.load()
            has_alpha = im.mode in ("RGBA", "LA", "PA") or (im.mode == "P" and "transparency" in im.info)
            if has_alpha:
                return np.array(im.convert("RGBA"))[..., 3] > 0
            return np.array(im.convert("L")) > 0
    except (OSError, ValueError, SyntaxError) as e:
        raise fail(f"corrupt or truncated ({e})") from None


def atomic_write(path: str, write) -> None:
    """Call ``write(tmp_path)`` then rename the temporary file onto ``path``.

    A failure removes the temporary file, so no partial output is ever left behind.
    """
    folder = os.path.dirname(os.path.abspath(path))
    base = os.path.basename(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=os.path.splitext(base)[1], dir=folder)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # as an ordinary new file (mkstemp makes it 0600)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def save_png(path: str, rgba: np.ndarray) -> None:
    """Write an (h, w, 4) or (h, w, 3) uint8 array as PNG, atomically."""
    from PIL import Image

    im = Image.fromarray(np.ascontiguousarray(rgba))
    atomic_write(path, lambda tmp: im.save(tmp, format="PNG"))
