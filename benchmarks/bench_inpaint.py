"""Time of each inpainting method on a 512x512 layer (the Noto dress, with the region a
72x200 px front part would take, ~5% of the image). Prints a table."""
from __future__ import annotations

import os
import time

import numpy as np

from puppet.imaging.inpaint import METHODS, inpaint
from puppet.imaging.io import load_rgba

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    rgba = load_rgba(os.path.join(HERE, "..", "assets", "noto-emoji", "emoji_u1f457.png"))
    rgb = np.ascontiguousarray(rgba[..., :3])
    hole = np.zeros(rgb.shape[:2], bool)
    hole[200:400, 150:222] = True
    hole &= rgba[..., 3] > 0
    print(f"512x512 layer, hole of {hole.sum()} px; ms, best of 3")
    print(f"{'method':10s} {'ms':>8s}")
    for m in METHODS[1:]:
        ts = []
        for _ in range(3):
            t = time.perf_counter()
            inpaint(rgb, hole, m)
            ts.append(time.perf_counter() - t)
        print(f"{m:10s} {min(ts) * 1e3:8.1f}")


if __name__ == "__main__":
    main()
