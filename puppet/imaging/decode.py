"""Pixels of any decoded image as 8-bit straight RGBA, as the image looks.

Pillow's own ``convert("RGBA")`` clips 16-bit grey to 255 (a mid-grey ``I;16`` image
turns white), truncates 16-bit colour to its high byte, and treats float images as
0..255; here 16-bit samples are scaled by /257 with rounding, float samples map
0.0..1.0 to 0..255, transparency keys are compared at full precision, CMYK and Lab
go through a colour transform, and EXIF orientation is applied.
"""
from __future__ import annotations

import numpy as np

#: Modes Pillow converts to RGBA exactly as they look (palette and colour-key
#: transparency included).
_PILLOW_EXACT = {"1", "L", "LA", "P", "PA", "RGB", "RGBA", "RGBa", "RGBX", "YCbCr", "HSV"}
_ALPHA_MODES = {"LA", "La", "PA", "RGBA", "RGBa"}


_LUT16 = ((np.arange(65536, dtype=np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
_BLOCK = 1 << 22  # samples converted at a time: temporaries stay small whatever the image


def scale16(a: np.ndarray) -> np.ndarray:
    """16-bit samples (any shape, values clipped to 0..65535) to 8-bit: round(v / 257)."""
    a = np.asarray(a)
    return _LUT16[a if a.dtype == np.uint16 else np.clip(a, 0, 65535)]


def scale_float(a: np.ndarray) -> np.ndarray:
    """Float samples to 8-bit: 0.0 -> 0, 1.0 -> 255, rounded half up, clipped; NaN -> 0."""
    a = np.ascontiguousarray(a)
    out = np.empty(a.shape, np.uint8)
    src, dst = a.reshape(-1), out.reshape(-1)
    for s in range(0, src.size, _BLOCK):
        v = np.nan_to_num(src[s:s + _BLOCK].astype(np.float64), nan=0.0, posinf=1.0, neginf=0.0)
        dst[s:s + _BLOCK] = np.floor(np.clip(v, 0.0, 1.0) * 255.0 + 0.5)
    return out


def luma(rgba: np.ndarray) -> np.ndarray:
    """Grey of (h, w, 4) uint8 pixels exactly as Pillow's ``convert("L")``, (h, w) uint8."""
    h, w = rgba.shape[:2]
    out = np.empty((h, w), np.uint8)
    step = max(1, _BLOCK // max(w, 1))
    for i in range(0, h, step):
        c = rgba[i:i + step, :, :3].astype(np.uint32)
        out[i:i + step] = (c[..., 0] * 19595 + c[..., 1] * 38470 + c[..., 2] * 7471 + 0x8000) >> 16
    return out


def _grey(g: np.ndarray, alpha: np.ndarray | None = None) -> np.ndarray:
    out = np.empty(g.shape + (4,), np.uint8)
    out[..., :3] = g[..., None]
    out[..., 3] = 255 if alpha is None else alpha
    return out


def pillow_to_rgba(im) -> tuple[np.ndarray, bool]:
    """A loaded Pillow image as (h, w, 4) uint8 RGBA and whether it has transparency.

    Raises
    ------
    ValueError
        A pixel format with no meaning as a picture.
    """
    mode = im.mode
    key = im.info.get("transparency")
    if mode.startswith("I;16") or mode == "I":
        raw = np.asarray(im)
        alpha = None if not isinstance(key, int) else np.where(raw == key, 0, 255).astype(np.uint8)
        return _grey(scale16(raw), alpha), alpha is not None
    if mode == "F":
        return _grey(scale_float(np.asarray(im))), False
    if mode in ("CMYK", "LAB"):
        return _colour_managed(im), False
    if mode == "La":
        im, mode = im.convert("LA"), "LA"
    if mode not in _PILLOW_EXACT:
        raise ValueError(f"pixel format {mode!r} is not supported")
    has_alpha = mode in _ALPHA_MODES or key is not None
    return np.array(im.convert("RGBA")), has_alpha


def _colour_managed(im) -> np.ndarray:
    """CMYK (with its embedded ICC profile when there is one) or CIE Lab to sRGB."""
    from PIL import Image, ImageCms

    rgb = None
    try:
        if im.mode == "LAB":
            t = ImageCms.buildTransform(ImageCms.createProfile("LAB"), ImageCms.createProfile("sRGB"), "LAB", "RGB")
            rgb = ImageCms.applyTransform(im, t)
        elif im.info.get("icc_profile"):
            import io

            src = ImageCms.ImageCmsProfile(io.BytesIO(im.info["icc_profile"]))
            t = ImageCms.buildTransform(src, ImageCms.createProfile("sRGB"), "CMYK", "RGB")
            rgb = ImageCms.applyTransform(im, t)
    except (ImageCms.PyCMSError, OSError, ValueError):
        rgb = None  # a broken profile: fall back to the plain formula
    if rgb is None:
        rgb = im.convert("RGB")  # CMYK: R = (255 - C)(255 - K) / 255, and so on
    return np.asarray(rgb.convert("RGBA") if isinstance(rgb, Image.Image) else rgb).copy()


def array_to_rgba(a: np.ndarray, *, bgr: bool = True) -> tuple[np.ndarray, bool]:
    """A decoded sample array (h, w), (h, w, 1|2|3|4) of uint8, uint16 or float as
    (h, w, 4) uint8 RGBA and whether it has an alpha channel. OpenCV's channel order
    (BGR, BGRA) unless ``bgr`` is False.
    """
    if a.ndim == 2:
        a = a[..., None]
    if a.dtype == np.uint8:
        v = a
    elif a.dtype == np.uint16:
        v = scale16(a)
    elif a.dtype.kind == "f":
        v = scale_float(a)
    else:
        raise ValueError(f"{a.dtype} samples are not supported")
    c = v.shape[2]
    if c in (1, 2):
        return _grey(v[..., 0], v[..., 1] if c == 2 else None), c == 2
    if c not in (3, 4):
        raise ValueError(f"{c} channels are not supported")
    if bgr:  # OpenCV's decoders gave it: its own swap, ~10x faster than a strided numpy copy
        import cv2

        return cv2.cvtColor(np.ascontiguousarray(v), cv2.COLOR_BGRA2RGBA if c == 4 else cv2.COLOR_BGR2RGBA), c == 4
    out = np.empty(v.shape[:2] + (4,), np.uint8)
    out[..., :3] = v[..., :3]
    out[..., 3] = v[..., 3] if c == 4 else 255
    return out, c == 4


def orient(a: np.ndarray, orientation: int) -> np.ndarray:
    """Apply an EXIF orientation (1-8) to an (h, w, ...) array, as viewers show it."""
    if orientation == 2:
        return a[:, ::-1]
    if orientation == 3:
        return a[::-1, ::-1]
    if orientation == 4:
        return a[::-1]
    if orientation == 5:
        return a.swapaxes(0, 1)
    if orientation == 6:
        return np.rot90(a, -1)
    if orientation == 7:
        return a[::-1, ::-1].swapaxes(0, 1)
    if orientation == 8:
        return np.rot90(a, 1)
    return a
