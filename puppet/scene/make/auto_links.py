"""Pieces of the automatic rig (:mod:`puppet.scene.make.anatomy`): the time limit, the
sweep that finds the layers whose boxes overlap, pixel overlaps, and the short segment
that links two overlapping layers where nothing better fits.

``link_segment``: for two layers whose pixels overlap (an arm drawn over the body), the
smaller one is "the part" and the overlap is where it meets the other. The segment is
centred at the point of the overlap that lies deepest in the part's end: among the
overlap's points at least half as deep as its deepest (distance to the overlap's edge),
those farthest (within a pixel) from the part's free pixels (those outside the other
layer), and of these the deepest (ties: the middle one). It is perpendicular to the
direction from there to the free pixels' centroid and shorter than the overlap's depth
there, so it lies inside both layers.
"""
from __future__ import annotations

import time

import numpy as np

from puppet.imaging.layered import ArtLayer

#: Overlaps less deep than this (pixels from their edge) get no link.
MIN_DEPTH = 3.0
#: Longest half-segment, in pixels.
MAX_HALF = 12.0
#: Seconds the automatic rig of one import (pins, then links) may take.
RIG_SECONDS = 30.0
#: An overlap narrower than this is nowhere MIN_DEPTH deep (a pixel's depth is at most
#: half the width, rounded up).
_THIN = int(2 * MIN_DEPTH - 1)


class Deadline:
    """A time limit for work that can stop part way: :meth:`passed` is True (and stays
    so, with ``hit`` set) once ``seconds`` have gone by since it was made."""

    def __init__(self, seconds: float):
        self.seconds, self.end, self.hit = seconds, time.monotonic() + seconds, False

    def left(self) -> float:
        """Seconds left (0 when passed)."""
        return max(self.end - time.monotonic(), 0.0)

    def passed(self) -> bool:
        self.hit = self.hit or time.monotonic() > self.end
        return self.hit


def box_pairs(boxes: list[tuple[int, int, int, int]]):
    """(i, j), i < j, of the boxes (x0, y0, x1, y1) that overlap: a sweep over x."""
    order = sorted(range(len(boxes)), key=lambda k: boxes[k][0])
    active: list[int] = []
    for k in order:
        x0, y0, x1, y1 = boxes[k]
        active = [a for a in active if boxes[a][2] > x0]
        for a in active:
            if boxes[a][1] < y1 and boxes[a][3] > y0:
                yield (a, k) if a < k else (k, a)
        active.append(k)


def overlap_count(a, ma: np.ndarray, b, mb: np.ndarray) -> int:
    """How many pixels two layers (boxes ``a``, ``b``, masks ``ma``, ``mb``) both cover;
    0 when the overlap is too thin anywhere to be :data:`MIN_DEPTH` deep."""
    ax0, ay0, ax1, ay1 = a
    bx0, by0, bx1, by1 = b
    x0, y0 = ax0 if ax0 > bx0 else bx0, ay0 if ay0 > by0 else by0
    x1, y1 = ax1 if ax1 < bx1 else bx1, ay1 if ay1 < by1 else by1
    if x1 - x0 < _THIN or y1 - y0 < _THIN:
        return 0
    return int(np.count_nonzero(ma[y0 - ay0:y1 - ay0, x0 - ax0:x1 - ax0] & mb[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0]))


def find_set(root: dict, x: str) -> str:
    while root.setdefault(x, x) != x:
        root[x] = root[root[x]]
        x = root[x]
    return x


def join_sets(root: dict, a: str, b: str) -> bool:
    """Union of a's and b's sets; False when they were one already."""
    ra, rb = find_set(root, a), find_set(root, b)
    if ra == rb:
        return False
    root[ra] = rb
    return True


def overlap_box(a: ArtLayer, b: ArtLayer):
    """(x0, y0, x1, y1), the canvas box two layers' boxes share, or None."""
    ax0, ay0, ax1, ay1 = a.bounds
    bx0, by0, bx1, by1 = b.bounds
    box = (max(ax0, bx0), max(ay0, by0), min(ax1, bx1), min(ay1, by1))
    return box if box[0] < box[2] and box[1] < box[3] else None


def crop_mask(lay: ArtLayer, box) -> np.ndarray:
    x0, y0, x1, y1 = box
    ox, oy = lay.offset
    return lay.rgba[y0 - oy:y1 - oy, x0 - ox:x1 - ox, 3] > 0


def link_segment(a: ArtLayer, b: ArtLayer):
    """The proposed segment [[x0, y0], [x1, y1]] (canvas) joining ``a`` and ``b``, the name
    of the part (the smaller layer) and the overlap's area in pixels; None when they do
    not overlap enough."""
    import cv2

    box = overlap_box(a, b)
    if box is None:
        return None
    both = crop_mask(a, box) & crop_mask(b, box)
    if both.sum() < 16:
        return None
    depth = cv2.distanceTransform(np.pad(both, 1).astype(np.uint8), cv2.DIST_L2, 5)[1:-1, 1:-1]
    if depth.max() < MIN_DEPTH:
        return None
    part, other = (a, b) if (a.rgba[..., 3] > 0).sum() <= (b.rgba[..., 3] > 0).sum() else (b, a)
    px0, py0, px1, py1 = part.bounds
    free = (part.rgba[..., 3] > 0) & ~_in_other(other, part.bounds)
    ys, xs = np.nonzero(depth >= max(0.5 * depth.max(), MIN_DEPTH))
    towards, deep = None, depth[ys, xs]
    if free.any():
        inside = np.pad(~free, 1, constant_values=True).astype(np.uint8)  # the box edge is no free pixel
        far = cv2.distanceTransform(inside, cv2.DIST_L2, 5)[1:-1, 1:-1][ys + box[1] - py0, xs + box[0] - px0]
        deep = np.where(far >= far.max() - 1.0, deep, -1.0)  # the farthest (within a pixel), then the deepest
        fy, fx = np.nonzero(free)
        towards = np.array([fx.mean() + px0, fy.mean() + py0])
    top = np.flatnonzero(deep >= deep.max() - 1e-6)  # ties: the one nearest their middle
    i = int(top[np.argmin((xs[top] - xs[top].mean()) ** 2 + (ys[top] - ys[top].mean()) ** 2)])
    centre = np.array([xs[i] + box[0] + 0.5, ys[i] + box[1] + 0.5])
    axis = np.array([1.0, 0.0]) if towards is None else towards - centre
    n = np.hypot(*axis)
    across = np.array([-axis[1], axis[0]]) / n if n > 1e-6 else np.array([1.0, 0.0])
    half = min(0.6 * float(depth[ys[i], xs[i]]), MAX_HALF)
    p, q = centre - half * across, centre + half * across
    seg = [[round(float(p[0]), 2), round(float(p[1]), 2)], [round(float(q[0]), 2), round(float(q[1]), 2)]]
    return seg, part.name, int(both.sum())


def _in_other(other: ArtLayer, box) -> np.ndarray:
    """(h, w) bool over ``box``: pixels of ``other``."""
    x0, y0, x1, y1 = box
    out = np.zeros((y1 - y0, x1 - x0), bool)
    ox0, oy0, ox1, oy1 = other.bounds
    cx0, cy0, cx1, cy1 = max(x0, ox0), max(y0, oy0), min(x1, ox1), min(y1, oy1)
    if cx0 < cx1 and cy0 < cy1:
        out[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0] = crop_mask(other, (cx0, cy0, cx1, cy1))
    return out
