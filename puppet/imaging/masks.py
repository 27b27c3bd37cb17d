"""Layer masks: which pixels of a layer's image belong to the layer.

All functions return (h, w) bool arrays in the pixel grid of the layer's image; shapes
given in canvas coordinates are shifted by the layer's offset first.
"""
from __future__ import annotations

import numpy as np



def has_transparency(rgba: np.ndarray) -> bool:
    """True when any pixel of an (h, w, 4) image is not fully opaque."""
    return bool((rgba[..., 3] < 255).any())


def luminance(rgba: np.ndarray) -> np.ndarray:
    """Rec. 601 luma of an (h, w, 4) uint8 image, (h, w) float32 in 0..255 (computed a
    band of rows at a time: no full-size float copy of the colours)."""
    h, w = rgba.shape[:2]
    out = np.empty((h, w), np.float32)
    weights = np.array([0.299, 0.587, 0.114], np.float32)
    step = max(1, (1 << 20) // max(w, 1))
    for i in range(0, h, step):
        out[i:i + step] = rgba[i:i + step, :, :3].astype(np.float32) @ weights
    return out


def alpha_mask(rgba: np.ndarray) -> np.ndarray:
    """Pixels with alpha > 0."""
    return rgba[..., 3] > 0


def threshold_mask(rgba: np.ndarray, threshold: float, invert: bool = False) -> np.ndarray:
    """Pixels darker than ``threshold`` (luminance < T) are object; ``invert`` flips.

    Fully transparent pixels are never object.
    """
    m = luminance(rgba) < threshold
    if invert:
        m = ~m
    return m & (rgba[..., 3] > 0)


#: Most row crossings a polygon mask may need (edges x pixel rows they span).
MAX_CROSSINGS = 10_000_000
#: Crossings rasterised at a time (bounds the memory of one step).
CHUNK = 1 << 20


def _edges(polygon, offset):
    P = np.asarray(polygon, np.float64).reshape(-1, 2) - np.asarray(offset, np.float64)
    A, B = P, np.roll(P, -1, axis=0)
    keep = A[:, 1] != B[:, 1]
    return A[keep], B[keep]


def _row_spans(A: np.ndarray, B: np.ndarray, h: int) -> tuple[np.ndarray, np.ndarray]:
    """First row and number of rows whose centre line y = i + 0.5 each edge crosses
    (half-open in y, so a vertex on a centre line counts once), clipped to [0, h)."""
    y0 = np.minimum(A[:, 1], B[:, 1])
    y1 = np.maximum(A[:, 1], B[:, 1])
    r0 = np.clip(np.ceil(y0 - 0.5), 0, h).astype(np.int64)
    r1 = np.clip(np.ceil(y1 - 0.5), 0, h).astype(np.int64)
    return r0, np.maximum(r1 - r0, 0)


def polygon_crossings(polygon: np.ndarray, offset=(0.0, 0.0), height: int = 16384) -> int:
    """Row crossings :func:`polygon_mask` computes for an image ``height`` rows tall
    (its work and memory), without computing them."""
    A, B = _edges(polygon, offset)
    return int(_row_spans(A, B, height)[1].sum())


def polygon_mask(shape: tuple[int, int], polygon: np.ndarray, offset=(0.0, 0.0)) -> np.ndarray:
    """Pixels whose centre lies inside a polygon given in canvas coordinates.

    Even-odd rule, so a self-intersecting polygon is filled like SVG's ``evenodd``: a
    centre is inside when a ray from it crosses the outline an odd number of times (the
    lobes of a figure eight are inside, the doubly wound core of a pentagram is not).
    Each pixel row's centre line is cut with the edges (half-open in y, so a vertex on
    the line counts once) and the parity of crossings at or left of a pixel centre
    decides (a centre exactly on an edge counts as inside on the left edge, outside on
    the right one). Memory is O(h w) bytes whatever the polygon: crossings are
    rasterised in chunks of :data:`CHUNK`.

    Parameters
    ----------
    shape : (h, w) of the image grid. polygon : (p, 2) canvas coordinates.
    offset : canvas position of the grid's top-left corner.

    Returns
    -------
    (h, w) bool.
    """
    h, w = shape
    A, B = _edges(polygon, offset)
    r0, counts = _row_spans(A, B, h)
    toggles = np.zeros((h, w + 1), np.uint8)  # parity of crossings at each (row, col)
    ends = np.cumsum(counts)
    e = 0
    while e < len(A):
        stop = int(np.searchsorted(ends, (ends[e - 1] if e else 0) + CHUNK, side="right"))
        stop = max(stop, e + 1)
        sl = slice(e, stop)
        c = counts[sl]
        edge = np.repeat(np.arange(e, stop), c)
        row = np.repeat(r0[sl], c) + (np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c))
        a, b = A[edge], B[edge]
        x = a[:, 0] + (row + 0.5 - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
        col = np.clip(np.ceil(x - 0.5), 0, w).astype(np.int64)
        flat = np.sort(row * (w + 1) + col)
        first = np.nonzero(np.r_[True, flat[1:] != flat[:-1]])[0]
        odd = np.diff(np.r_[first, len(flat)]) & 1 == 1
        toggles.ravel()[flat[first[odd]]] ^= 1
        e = stop
    return (np.cumsum(toggles[:, :w], axis=1, dtype=np.uint8) & 1).astype(bool)  # mod 256 keeps parity


def _overlap(offset, image_shape: tuple[int, int], canvas_shape: tuple[int, int]):
    """Where a layer image of ``image_shape`` (h, w) placed at canvas ``offset`` (rounded to
    whole pixels) meets a canvas of ``canvas_shape`` (H, W): (canvas slices, image slices),
    or None when they do not meet."""
    ox, oy = int(round(offset[0])), int(round(offset[1]))
    (h, w), (H, W) = image_shape, canvas_shape
    y0, x0, y1, x1 = max(oy, 0), max(ox, 0), min(oy + h, H), min(ox + w, W)
    if y1 <= y0 or x1 <= x0:
        return None
    return (slice(y0, y1), slice(x0, x1)), (slice(y0 - oy, y1 - oy), slice(x0 - ox, x1 - ox))


def canvas_to_image(canvas_mask: np.ndarray, offset, shape: tuple[int, int]) -> np.ndarray:
    """A canvas-grid mask (H, W) moved into the grid of a layer image of ``shape`` (h, w)
    placed at canvas ``offset`` (rounded to whole pixels): (h, w) bool, False off the canvas."""
    out = np.zeros(shape, bool)
    both = _overlap(offset, shape, canvas_mask.shape)
    if both is not None:
        out[both[1]] = canvas_mask[both[0]]
    return out


def image_to_canvas(mask: np.ndarray, offset, canvas) -> np.ndarray:
    """A layer image's mask (h, w), placed at canvas ``offset`` (rounded to whole pixels),
    on the canvas grid of size ``canvas`` (W, H): (H, W) bool (the inverse of
    :func:`canvas_to_image`)."""
    out = np.zeros((int(canvas[1]), int(canvas[0])), bool)
    both = _overlap(offset, mask.shape, out.shape)
    if both is not None:
        out[both[0]] = mask[both[1]]
    return out


def rect_mask(shape: tuple[int, int], rect, offset=(0.0, 0.0)) -> np.ndarray:
    """Pixels whose centre lies inside ``[x, y, w, h]`` (canvas coordinates)."""
    h, w = shape
    x0, y0, rw, rh = (float(v) for v in rect)
    x0 -= offset[0]
    y0 -= offset[1]
    cx = np.arange(w) + 0.5
    cy = np.arange(h) + 0.5
    mx = (cx >= x0) & (cx < x0 + rw)
    my = (cy >= y0) & (cy < y0 + rh)
    return my[:, None] & mx[None, :]


def grabcut_mask(rgba: np.ndarray, rect, offset=(0.0, 0.0), iterations: int = 5) -> np.ndarray:
    """Foreground of a photo inside ``[x, y, w, h]`` by GrabCut, with bounded work on any
    picture and any rectangle (:func:`puppet.imaging.grabcut.grabcut`)."""
    from puppet.imaging.grabcut import grabcut  # lazy: scenes masked by GrabCut only

    x0 = int(round(rect[0] - offset[0]))
    y0 = int(round(rect[1] - offset[1]))
    rw, rh = int(round(rect[2])), int(round(rect[3]))
    return grabcut(np.ascontiguousarray(rgba[..., 2::-1]), (x0, y0, rw, rh), iterations)
