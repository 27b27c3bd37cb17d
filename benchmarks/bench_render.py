"""Frame time of the depth-peeling compositor on synthetic puppets.

Run: ``python benchmarks/bench_render.py [--frames N]`` from the repository root.
Prints one row per scene: ms per frame (median over N animated frames, every frame
with new deformed vertices and depths, textures cached), the first frame (texture
upload included), and the peels used. ``max_peels=1`` is a plain depth test with no
transparency sorting (what peeling costs on top of it).
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from puppet.render.compositor import Compositor, DrawLayer  # noqa: E402


def blob_image(w: int, h: int, colour, rng) -> np.ndarray:
    """Soft-edged (anti-aliased) ellipse with some texture noise, straight RGBA."""
    ys, xs = np.mgrid[0:h, 0:w]
    r = np.hypot((xs + 0.5 - w / 2) / (w / 2 - 3), (ys + 0.5 - h / 2) / (h / 2 - 3))
    alpha = np.clip((1 - r) * min(w, h) / 2, 0, 1)
    img = np.zeros((h, w, 4), np.uint8)
    noise = rng.integers(-25, 25, (h, w, 1))
    img[..., :3] = np.clip(np.asarray(colour) + noise, 0, 255)
    img[..., 3] = np.rint(alpha * 255)
    return img


def grid(x0, y0, w, h, n):
    xs, ys = np.linspace(x0, x0 + w, n + 1), np.linspace(y0, y0 + h, n + 1)
    V = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    a, b, c, d = i, i + 1, i + n + 1, i + n + 2
    F = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                        np.stack([a, d, c], -1).reshape(-1, 3)]).astype(np.int32)
    return V, F


def make_scene(canvas, n_layers, cells, layer_size, seed=0):
    """Layers of soft blobs scattered over the canvas: (image, offset, rest, tris, phase)."""
    rng = np.random.default_rng(seed)
    cw, ch = canvas
    lw, lh = layer_size
    out = []
    for i in range(n_layers):
        colour = rng.integers(40, 230, 3)
        img = blob_image(lw, lh, colour, rng)
        off = (float(rng.uniform(0, cw - lw)), float(rng.uniform(0, ch - lh)))
        rest, tri = grid(off[0], off[1], lw, lh, cells)
        out.append((img, off, rest, tri, rng.uniform(0, 2 * math.pi)))
    return out


def frame_layers(scene, t):
    """Deformed layers at time t: a bend per layer, depth = index + a wave along x."""
    layers = []
    for i, (img, off, rest, tri, phase) in enumerate(scene):
        h, w = img.shape[:2]
        u = (rest[:, 0] - off[0]) / w
        bend = 0.12 * h * np.sin(2 * math.pi * (u + t) + phase)
        deformed = rest + np.stack([0.05 * w * np.sin(phase + t) * np.ones_like(u), bend], 1)
        depth = i + 2.5 * np.sin(2 * math.pi * u + phase + t)
        layers.append(DrawLayer(f"L{i}", img, off, rest, deformed, tri, depth))
    return layers


def bench(name, canvas, n_layers, cells, layer_size, frames, max_peels):
    scene = make_scene(canvas, n_layers, cells, layer_size)
    comp = Compositor(max_peels=max_peels)
    try:
        t0 = time.perf_counter()
        comp.render(frame_layers(scene, 0.0), canvas, background=(255, 255, 255, 255))
        first = (time.perf_counter() - t0) * 1000
        times, peels = [], []
        for k in range(frames):
            layers = frame_layers(scene, 0.05 * (k + 1))
            t0 = time.perf_counter()
            comp.render(layers, canvas, background=(255, 255, 255, 255))
            times.append((time.perf_counter() - t0) * 1000)
            peels.append(comp.last_peels)
    finally:
        comp.release()
    tris = sum(len(s[3]) for s in scene)
    print(f"| {name:<22} | {f'{canvas[0]}x{canvas[1]}':<9} | {n_layers:>6} | {tris:>9} | "
          f"{max_peels:>9} | {min(peels)}-{max(peels):<3} | {first:>8.1f} | "
          f"{statistics.median(times):>8.1f} | {max(times):>7.1f} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20)
    args = parser.parse_args(argv)
    print(f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', '(default)')}, "
          f"{os.cpu_count()} CPUs, {args.frames} frames per row")
    print("| scene                  | canvas    | layers | triangles | max_peels | peels "
          "| first ms | ms/frame |  max ms |")
    print("|---|---|---|---|---|---|---|---|---|")
    for max_peels in (6, 1):
        bench("600x500, 8 x 2k tris", (600, 500), 8, 32, (220, 260), args.frames, max_peels)
        bench("1080p, 5 x 10k tris", (1920, 1080), 5, 71, (900, 700), args.frames, max_peels)


if __name__ == "__main__":
    main()
