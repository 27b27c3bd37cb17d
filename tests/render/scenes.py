"""Small layer scenes for the compositor tests (numpy only)."""
from __future__ import annotations

import math

import numpy as np

from puppet.render.layers import DrawLayer

CANVAS = (64, 48)


def rect_image(w, h, box, colour, *, transparent=(0, 0, 0)):
    """Image with an anti-aliased rectangle: exact area coverage of box (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = box
    xs, ys = np.arange(w), np.arange(h)
    cx = np.clip(np.minimum(xs + 1, x1) - np.maximum(xs, x0), 0, 1)
    cy = np.clip(np.minimum(ys + 1, y1) - np.maximum(ys, y0), 0, 1)
    img = np.zeros((h, w, 4), np.uint8)
    img[..., :3] = transparent
    alpha = np.rint(np.outer(cy, cx) * 255).astype(np.uint8)
    colour = np.broadcast_to(np.asarray(colour, np.uint8), (h, w, 3))
    img[alpha > 0, :3] = colour[alpha > 0]
    img[..., 3] = alpha
    return img


def disc_image(size, radius, colour, *, transparent=(0, 0, 0)):
    """Anti-aliased disc (8x8 supersampled coverage); transparent pixels get `transparent`."""
    sub = (np.arange(size * 8) + 0.5) / 8 - size / 2
    inside = (sub[None, :] ** 2 + sub[:, None] ** 2) <= radius ** 2
    alpha = inside.reshape(size, 8, size, 8).mean(axis=(1, 3))
    img = np.zeros((size, size, 4), np.uint8)
    img[..., :3] = transparent
    img[alpha > 0, :3] = colour
    img[..., 3] = np.rint(alpha * 255).astype(np.uint8)
    return img


def grid_mesh(x0, y0, x1, y1, nx, ny):
    """Vertices (n, 2) and triangles (m, 3) of an nx x ny cell grid over a rectangle."""
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    V = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    i = np.arange(ny)[:, None] * (nx + 1) + np.arange(nx)[None, :]
    a, b, c, d = i, i + 1, i + nx + 1, i + nx + 2
    F = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                        np.stack([a, d, c], -1).reshape(-1, 3)])
    return V, F


def rotate(P, degrees, centre):
    t = math.radians(degrees)
    R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    return (P - centre) @ R.T + centre


def image_layer(key, image, offset, *, nx=4, ny=4, deform=None, depth=0.0):
    """A layer whose mesh covers its whole image rectangle."""
    h, w = image.shape[:2]
    rest, tri = grid_mesh(offset[0], offset[1], offset[0] + w, offset[1] + h, nx, ny)
    deformed = rest.copy() if deform is None else deform(rest)
    d = depth(rest) if callable(depth) else np.full(len(rest), float(depth))
    return DrawLayer(key, image, offset, rest, deformed, tri, d)


def crossing_scene():
    """Red horizontal strip whose depth falls from 3 (left) to -1 (right) across two blue
    vertical bars at depth ~1: red is in front at the left bar, behind at the right."""
    red_img = rect_image(60, 14, (2.3, 2.4, 57.6, 11.7), (220, 30, 30))
    red = image_layer("red", red_img, (2, 17), nx=6, ny=2,
                      deform=lambda P: rotate(P, 4, (32, 24)),
                      depth=lambda P: 3 - 4 * (P[:, 0] - 2) / 60)
    blue_img = np.maximum(rect_image(52, 44, (3.3, 2.2, 13.6, 41.7), (30, 40, 210)),
                          rect_image(52, 44, (35.4, 2.2, 45.7, 41.7), (30, 40, 210)))
    v1, f1 = grid_mesh(7, 2, 22, 46, 2, 4)
    v2, f2 = grid_mesh(38, 2, 54, 46, 2, 4)
    rest = np.concatenate([v1, v2])
    blue = DrawLayer("blue", blue_img, (6, 2), rest, rotate(rest, -3, (32, 24)),
                     np.concatenate([f1, f2 + len(v1)]), 1 + 0.1 * (rest[:, 1] - 24) / 24)
    return [red, blue]


def disc_over(back_colour, front_colour, transparent):
    """A soft disc in front of a full rectangle, the front layer listed first."""
    back = image_layer("back", rect_image(48, 40, (0, 0, 48, 40), back_colour), (0, 0),
                       nx=2, ny=2, depth=0.0)
    front = image_layer("front", disc_image(30, 11, front_colour, transparent=transparent),
                        (9, 5), nx=5, ny=5, depth=1.0,
                        deform=lambda P: rotate(P, 10, (24, 20)) + (0.3, 0.2))
    return [front, back]


def translucent_stack(n=3, alphas=(150, 100, 200, 120, 180)):
    """n overlapping translucent rectangles with tilted depths that do not cross."""
    img = rect_image(40, 30, (2.5, 2.5, 37.5, 27.5), (255, 255, 255))
    colours = [(255, 0, 0), (0, 200, 0), (0, 0, 255), (240, 200, 0), (0, 200, 220)]
    layers = []
    for i in range(n):
        im = img.copy()
        im[..., :3] = colours[i]
        im[..., 3] = (im[..., 3].astype(int) * alphas[i] // 255).astype(np.uint8)
        layers.append(image_layer(f"t{i}", im, (4 + 8 * (i % 3), 3 + 6 * (i % 3)), nx=3, ny=2,
                                  depth=lambda P, i=i: (i * 7 % n) + 0.01 * P[:, 0]))
    return layers


def folded_strip(slope, *, key="fold"):
    """Red-to-green soft strip folded at x = 32: its right half lies over its left half.

    Depth ``slope * (x - 32)`` of the rest x: 0 gives one depth everywhere, so the two
    halves overlap at exactly equal depth (an elbow folded at one pin depth).
    """
    img = rect_image(60, 12, (2.4, 2.3, 57.6, 9.7), (0, 0, 0))
    img[..., 0] = np.where(img[..., 3] > 0, np.linspace(255, 0, 60)[None, :], 0)
    img[..., 1] = np.where(img[..., 3] > 0, np.linspace(0, 255, 60)[None, :], 0)
    rest, tri = grid_mesh(2, 18, 62, 30, 15, 2)
    x = rest[:, 0]
    deformed = np.stack([np.where(x > 32, 64 - x, x), rest[:, 1] + 0.15 * np.maximum(x - 32, 0)], 1)
    return DrawLayer(key, img, (2, 18), rest, deformed, tri, slope * (x - 32))


def random_scene(seed, canvas):
    """2-5 translucent soft discs, bent and rotated, with wavy depths that cross."""
    rng = np.random.default_rng(seed)
    layers = []
    for i in range(int(rng.integers(2, 6))):
        w = int(rng.integers(20, 60))
        img = disc_image(w, w / 2 - 3, tuple(int(v) for v in rng.integers(0, 256, 3)))
        img[..., 3] = np.rint(img[..., 3] * rng.uniform(0.4, 1.0)).astype(np.uint8)
        off = (float(rng.uniform(-5, canvas[0] - w + 5)), float(rng.uniform(-5, canvas[1] - w + 5)))
        angle, bend = rng.uniform(-40, 40), rng.uniform(-0.3, 0.3)
        amp, phase = rng.uniform(0, 3), rng.uniform(0, 6)

        def deform(P, angle=angle, bend=bend, centre=np.add(off, w / 2), w=w):
            Q = rotate(P, angle, centre)
            Q[:, 1] += bend * (Q[:, 0] - centre[0]) ** 2 / w
            return Q

        def depth(P, i=i, a=amp, p=phase):
            return i + a * np.sin(P[:, 0] / 15 + p)
        layers.append(image_layer(f"r{i}", img, off, nx=int(rng.integers(2, 8)),
                                  ny=int(rng.integers(2, 8)), deform=deform, depth=depth))
    return layers


def distance_to_segments(P, A, B):
    """Distance of each point P (k, 2) to the nearest segment A[i]-B[i]."""
    d = B - A
    t = np.clip(((P[:, None] - A[None]) * d[None]).sum(-1) / (d * d).sum(-1)[None], 0, 1)
    closest = A[None] + t[..., None] * d[None]
    return np.linalg.norm(P[:, None] - closest, axis=-1).min(axis=1)
