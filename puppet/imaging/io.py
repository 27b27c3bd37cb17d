"""Image loading with limits (writing lives in :mod:`puppet.output`, re-exported here).

Every image a user names goes through :func:`load_rgba`, which refuses missing, corrupt,
non-image and absurdly large files (decompression bombs) with an :class:`ImageError`
naming the file, before any pixel is decoded.
"""
from __future__ import annotations

import os
import warnings

import numpy as np

from puppet.errors import ImageError
from puppet.output import atomic_write, save_png  # noqa: F401  (re-exported: one output mechanism)

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
