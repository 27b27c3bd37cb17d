"""Make ``walk/``: a 24-frame 640x480 clip of the Kenney toon adventurer walking right over a
pale backdrop (the idle and walk sprites alternating, scaled 3x, a small bob), for docs/video.md.

Run from the project root: ``.venv/bin/python assets/kenney-toon/make_walk.py``.
"""
from __future__ import annotations

import os

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
W, H, N = 640, 480, 24


def backdrop() -> Image.Image:
    """A pale flat sky with white clouds and a light ground band: every pixel's luminance >= 240."""
    img = np.zeros((H, W, 3))
    img[:] = (240, 247, 255)
    yy, xx = np.mgrid[0:H, 0:W]
    for cx, cy, r in ((120, 90, 50), (420, 70, 70), (560, 150, 40)):
        img[(xx - cx) ** 2 + 3 * (yy - cy) ** 2 < r * r] = (255, 255, 255)
    img[400:] = (244, 248, 236)
    img[400:402] = (238, 244, 228)
    return Image.fromarray(np.clip(img, 0, 255).astype(np.uint8))


def walk_frames(n: int = N):
    """The clip's frames as (H, W, 3) uint8 arrays; past frame 23 the walk turns back and forth."""
    sprites = [Image.open(os.path.join(HERE, f"femaleAdventurer_{k}.png")).convert("RGBA") for k in ("idle", "walk3")]
    sprites = [s.resize((s.width * 3, s.height * 3), Image.LANCZOS) for s in sprites]
    bg = backdrop()
    for i in range(n):
        j = i % (2 * (N - 1))
        j = j if j < N else 2 * (N - 1) - j  # ping-pong over the 24 positions
        s = sprites[(i // 3) % 2]
        x, y = 60 + 10 * j, 30 - (4 if (i // 3) % 2 else 0)
        f = bg.copy()
        f.paste(s, (x, y), s)
        yield np.asarray(f)


def main() -> None:
    out = os.path.join(HERE, "walk")
    os.makedirs(out, exist_ok=True)
    for i, a in enumerate(walk_frames(N)):
        f = Image.fromarray(a).quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
        f.save(os.path.join(out, f"frame_{i:02d}.png"), optimize=True)  # a palette keeps the files small


if __name__ == "__main__":
    main()
