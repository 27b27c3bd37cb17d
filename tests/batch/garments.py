"""Garment pictures for template-mode tests, made from the bundled images: similarity
copies (known transform), a re-proportioned t-shirt (known smooth warp), a t-shirt
assembled from Kenney parts, a circle."""
from __future__ import annotations

import json
import os

import numpy as np
from PIL import Image

from puppet.imaging.io import load_rgba

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ASSETS = os.path.join(ROOT, "assets")
TSHIRT = os.path.join(ASSETS, "noto-emoji", "emoji_u1f455.png")
DRESS = os.path.join(ASSETS, "noto-emoji", "emoji_u1f457.png")
KENNEY = os.path.join(ASSETS, "kenney-character")
TSHIRT_TEMPLATE = os.path.join(ASSETS, "scenes", "tshirt-garment.json")


def save(path, rgba) -> str:
    Image.fromarray(np.asarray(rgba, np.uint8)).save(path)
    return str(path)


def similar_copy(src: str, dst, *, scale: float, angle: float, shift, size, nearest: bool = False,
                 ) -> tuple[complex, complex]:
    """Warp ``src`` by ``z -> a z + b`` (canvas coordinates, pixel centres at +0.5,
    ``angle`` degrees in raw x/y-down axes) into a ``size`` = (w, h) picture, bilinear
    (or ``nearest`` neighbour: an exact integer upscale keeps hard mask edges).

    Returns ``(a, b)`` as complex numbers."""
    import cv2

    rgba = load_rgba(src)
    a = scale * np.exp(1j * np.radians(angle))
    b = complex(*shift)
    c = 0.5 + 0.5j  # cv2 indexes pixel centres at integers
    t = a * c + b - c
    M = np.array([[a.real, -a.imag, t.real], [a.imag, a.real, t.imag]])
    save(dst, cv2.warpAffine(rgba, M, tuple(size), flags=cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR,
                                    borderValue=(0, 0, 0, 0)))
    return a, b


#: The re-proportioned t-shirt: wider, shorter, sleeves drooping.
WARP = {"sx": 1.12, "sy": 0.92, "droop": 30.0, "size": (560, 512)}


def warp_forward(P, *, sx=WARP["sx"], sy=WARP["sy"], droop=WARP["droop"], size=WARP["size"]) -> np.ndarray:
    """Where :func:`reproportioned` sends points of the 512x512 t-shirt, (k, 2)."""
    P = np.asarray(P, float)
    u = P[:, 0] - 256.0
    return np.stack([size[0] / 2 + sx * u, sy * P[:, 1] + droop * (u / 256.0) ** 2], axis=1)


def reproportioned(dst, *, sx=WARP["sx"], sy=WARP["sy"], droop=WARP["droop"], size=WARP["size"]) -> str:
    """The noto t-shirt made wider (``sx``), shorter (``sy``) with drooping sleeves."""
    import cv2

    rgba = load_rgba(TSHIRT)
    w, h = size
    x, y = np.meshgrid(np.arange(w, dtype=np.float64) + 0.5, np.arange(h, dtype=np.float64) + 0.5)
    u = (x - w / 2) / sx
    v = (y - droop * (u / 256.0) ** 2) / sy
    mx, my = (u + 256.0 - 0.5).astype(np.float32), (v - 0.5).astype(np.float32)
    return save(dst, cv2.remap(rgba, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                               borderValue=(0, 0, 0, 0)))


def kenney_tshirt(dst, *, shirt="blueShirt1.png", arm="blueArm_short.png", overlap=38, drop=4):
    """A short-sleeved t-shirt assembled from Kenney's sleeveless shirt and two short
    sleeves (the left one mirrored). Returns (path, x of the shirt's left and right edge)."""
    s = Image.open(os.path.join(KENNEY, shirt)).convert("RGBA")
    a = Image.open(os.path.join(KENNEY, arm)).convert("RGBA")
    x0 = a.width - overlap
    out = Image.new("RGBA", (s.width + 2 * x0, max(s.height, a.height + drop)), (0, 0, 0, 0))
    out.alpha_composite(a, (x0 + s.width - overlap, drop))
    out.alpha_composite(a.transpose(Image.FLIP_LEFT_RIGHT), (0, drop))
    out.alpha_composite(s, (x0, 0))
    out.save(dst)
    return str(dst), (x0, x0 + s.width)


def circle(dst, size=200, r=80) -> str:
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    a = np.zeros((size, size, 4), np.uint8)
    inside = (xx - size / 2) ** 2 + (yy - size / 2) ** 2 <= r * r
    a[inside] = (200, 60, 60, 255)
    return save(dst, a)


def caged_template(folder, cage: dict, poses: dict | None = None, keys: list | None = None) -> str:
    """The bundled t-shirt template with ``layers[0].cage = cage`` (its image path made
    absolute), ``poses`` added and animation ``keys`` inserted after the first, written
    to ``folder/caged.json``; returns the path."""
    with open(TSHIRT_TEMPLATE) as f:
        t = json.load(f)
    L = t["layers"][0]
    L["image"] = os.path.normpath(os.path.join(os.path.dirname(TSHIRT_TEMPLATE), L["image"]))
    L["cage"] = cage
    t["poses"].update(poses or {})
    t["animation"]["keys"][1:1] = keys or []
    path = os.path.join(folder, "caged.json")
    with open(path, "w") as f:
        json.dump(t, f)
    return path
