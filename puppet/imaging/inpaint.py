"""Refill the pixels of a layer that layers in front of it took from the same picture.

``inpaint(rgb, hole, method)`` returns a copy of ``rgb`` whose ``hole`` pixels are replaced
by a fill computed from the pixels around them. Methods:

``pyramid``
    Push-pull fill over a Gaussian-like pyramid (Ogden, Adelson, Bergen & Burt,
    "Pyramid-based computer graphics", 1985): known pixels are averaged down level by
    level with their coverage as weight, then holes are filled top-down from the
    coarser level. Smooth, fast, no texture synthesis.
``telea``, ``ns``
    OpenCV's ``cv2.inpaint`` (Telea 2004 fast marching; Bertalmio et al. Navier-Stokes).
``fsr``
    OpenCV contrib ``xphoto.inpaint`` with frequency-selective reconstruction (fast variant).
``outline``
    ``telea``; where the layer's art has an outline (:func:`outline_ink`), from its pixels
    other than the ink, and the outline drawn on across the hole along the layer's edge
    (:func:`draw_outline`; Layer via Cut on outlined art).
"""
from __future__ import annotations

import numpy as np

METHODS = ("none", "pyramid", "telea", "ns", "fsr", "outline")
#: the widest outline :func:`outline_ink` looks for (px)
OUTLINE_MAX = 32
#: pixels within this RGB distance of an outline's colour are that ink
INK = 60.0
#: :func:`ink_near` works in the hole's box grown by this many pixels
AROUND = 2 * OUTLINE_MAX + 40


def _box_down(a: np.ndarray) -> np.ndarray:
    """Sum 2x2 blocks (odd sizes padded by edge replication)."""
    h, w = a.shape[:2]
    if h % 2 or w % 2:
        pad = [(0, h % 2), (0, w % 2)] + [(0, 0)] * (a.ndim - 2)
        a = np.pad(a, pad, mode="edge")
    return a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2]


def _blur(a: np.ndarray) -> np.ndarray:
    """Separable [1 4 6 4 1]/16 blur, edges replicated."""
    k = np.array([1, 4, 6, 4, 1], np.float64) / 16.0
    for axis in (0, 1):
        pad = [(0, 0)] * a.ndim
        pad[axis] = (2, 2)
        p = np.pad(a, pad, mode="edge")
        n = a.shape[axis]
        a = sum(k[i] * np.take(p, np.arange(i, i + n), axis=axis) for i in range(5))
    return a


def pyramid_fill(rgb: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """Push-pull pyramid fill of ``hole`` pixels in an (h, w, c) image.

    Parameters
    ----------
    rgb : (h, w, c) uint8 or float image.
    hole : (h, w) bool, True where the pixel must be filled.

    Returns
    -------
    (h, w, c) array of ``rgb``'s dtype; pixels outside ``hole`` are unchanged.
    """
    img = rgb.astype(np.float64)
    known = (~hole).astype(np.float64)
    if known.sum() == 0:
        return rgb.copy()
    # push: pre-multiplied colour and coverage, blurred and halved level by level
    levels = [(img * known[..., None], known)]
    while min(levels[-1][1].shape) > 1 and levels[-1][1].min() == 0:
        c, k = levels[-1]
        c, k = _blur(c), _blur(k)
        levels.append((_box_down(c) / 4.0, _box_down(k) / 4.0))
    # pull: from the coarsest level down, fill what is not fully covered
    c, k = levels[-1]
    fill = c / np.maximum(k, 1e-12)[..., None]
    for c, k in reversed(levels[:-1]):
        h, w = k.shape
        up = np.repeat(np.repeat(fill, 2, axis=0), 2, axis=1)[:h, :w]
        up = _blur(up)
        own = c / np.maximum(k, 1e-12)[..., None]
        t = np.clip(k, 0.0, 1.0)[..., None]
        fill = t * own + (1.0 - t) * up
    out = img.copy()
    out[hole] = fill[hole]
    if np.issubdtype(rgb.dtype, np.integer):
        return np.clip(np.rint(out), 0, 255).astype(rgb.dtype)
    return out.astype(rgb.dtype)


def inpaint(rgb: np.ndarray, hole: np.ndarray, method: str, *, radius: float = 5.0) -> np.ndarray:
    """Fill ``hole`` pixels of an (h, w, 3) uint8 image by ``method`` (see module doc;
    ``outline`` needs the layer's mask, :func:`inpaint_layer`: here it is ``telea``)."""
    if method == "none" or not hole.any():
        return rgb.copy()
    method = "telea" if method == "outline" else method
    if method == "pyramid":
        return pyramid_fill(rgb, hole)
    import cv2

    src = np.ascontiguousarray(rgb[..., :3])
    m8 = hole.astype(np.uint8) * 255
    if method == "telea":
        out = cv2.inpaint(src, m8, radius, cv2.INPAINT_TELEA)
    elif method == "ns":
        out = cv2.inpaint(src, m8, radius, cv2.INPAINT_NS)
    elif method == "fsr":
        out = src.copy()
        # xphoto wants the mask of *valid* pixels (non-zero = known)
        valid = (~hole).astype(np.uint8) * 255
        cv2.xphoto.inpaint(src, valid, out, cv2.xphoto.INPAINT_FSR_FAST)
    else:
        raise ValueError(f"unknown inpainting method {method!r}")
    res = rgb.copy()
    res[hole, :3] = out[hole]  # some methods touch known pixels too; keep them exactly
    return res


def distance_out(mask: np.ndarray) -> np.ndarray:
    """Each pixel's Euclidean distance to the nearest pixel off ``mask`` (the image's border
    counted as off it): (h, w) float32."""
    import cv2  # lazy: refills only

    d = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return d[1:-1, 1:-1]


def outline_ink(rgb: np.ndarray, known: np.ndarray, depth: np.ndarray,
                deepest: float = OUTLINE_MAX) -> tuple[np.ndarray, int] | None:
    """The colour and thickness (px) of the outline a drawing has along its edge, or None.

    Parameters
    ----------
    rgb : (h, w, 3+) image. known : (h, w) bool, the pixels to look at.
    depth : (h, w) float, their distance to the layer's outside (:func:`distance_out`).
    deepest : the thickest outline looked for.

    The ink is the median colour of the pixels 2-3 px in (inside the anti-aliased fringe);
    the thickness (3 px at least), the depth down to which most pixels at each depth are
    within :data:`INK` of it. No outline: fewer than 8 such pixels, ink as deep as
    ``deepest``, or an inside (just deeper than the outline) of the ink's colour too.
    """
    rgb = rgb[..., :3].astype(np.float32)
    rim = known & (depth >= 2) & (depth <= 3)
    if rim.sum() < 8:
        return None
    ink = np.median(rgb[rim], axis=0)
    inky = np.linalg.norm(rgb - ink, axis=-1) <= INK
    t = 3
    while t < deepest:
        ring = known & (depth > t) & (depth <= t + 1)
        if not ring.any() or inky[ring].mean() < 0.5:
            break
        t += 1
    inside = known & (depth > t + 1) & (depth <= t + 4)
    if t >= deepest or not inside.any() or inky[inside].mean() >= 0.5:
        return None
    return ink, t


def ink_near(rgb: np.ndarray, mask: np.ndarray, hole: np.ndarray):
    """:func:`outline_ink` of a layer's pixels (``mask`` without ``hole``) within
    2 :data:`OUTLINE_MAX` of ``hole``, found in the hole's box grown by :data:`AROUND`
    (far enough that the box's sides, counted as outside, leave those depths alone).

    Returns
    -------
    found : (ink, thickness) or None. box : (rows, cols) slices. depth : (h, w) float,
    :func:`distance_out` of the mask in the box.
    """
    import cv2  # lazy: refills only

    rows, cols = np.flatnonzero(hole.any(axis=1)), np.flatnonzero(hole.any(axis=0))
    box = (slice(max(rows[0] - AROUND, 0), rows[-1] + AROUND + 1),
           slice(max(cols[0] - AROUND, 0), cols[-1] + AROUND + 1))
    m, h = mask[box], hole[box]
    depth = distance_out(m)
    k = 2 * OUTLINE_MAX + 1
    near = cv2.dilate(h.astype(np.uint8), np.ones((k, k), np.uint8)).astype(bool)
    return outline_ink(rgb[box], m & ~h & near, depth), box, depth


def draw_outline(rgb: np.ndarray, mask: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``rgb`` with ``hole`` refilled: by ``telea`` from the layer's pixels other than its
    ink (near the hole, the ink's pixels, the pixel round them and the pixels off the
    mask count as unknown, so the fill does not smear the line into the inside), and the
    layer's outline drawn on across the hole along the edge of ``mask`` (colour and
    thickness from the layer's pixels near the hole, :func:`outline_ink`; its inner edge
    anti-aliased over a pixel). Only ``telea`` where the art has no outline."""
    import cv2  # lazy: refills only

    if not hole.any():
        return rgb.copy()
    found, box, depth = ink_near(rgb, mask, hole)
    if found is None:
        return inpaint(rgb, hole, "telea")
    ink, t = found
    c, m, h = rgb[box], mask[box], hole[box]
    k = 2 * t + 7
    near = cv2.dilate(h.astype(np.uint8), np.ones((k, k), np.uint8)).astype(bool)
    inky = (np.linalg.norm(c[..., :3].astype(np.float32) - ink, axis=-1) <= INK).astype(np.uint8)
    inky = near & (cv2.dilate(inky, np.ones((3, 3), np.uint8)).astype(bool) | ~m)  # its rim, the outside
    filled = inpaint(np.ascontiguousarray(c), h | inky, "telea")
    cover = np.clip(t + 1.0 - depth, 0.0, 1.0)[h][:, None]  # 1 down to depth t, 0 from t + 1
    out = rgb.copy()
    out[box][h, :3] = np.rint(cover * ink + (1.0 - cover) * filled[h, :3]).astype(rgb.dtype)
    return out


def inpaint_layer(rgba: np.ndarray, mask: np.ndarray, hole: np.ndarray, method: str) -> np.ndarray:
    """Refill ``hole`` of a layer from the layer's own pixels only.

    Pixels outside the layer's ``mask`` (transparent black, other parts of a picture)
    must not bleed into the fill, so they are first given the layer's own colours by a
    push-pull fill from ``mask & ~hole``; then ``method`` fills the hole.

    Parameters
    ----------
    rgba : (h, w, 4) uint8. mask, hole : (h, w) bool, ``hole`` inside ``mask``.

    Returns
    -------
    (h, w, 4) uint8: ``rgba`` with the hole's RGB replaced (alpha unchanged).
    """
    known = mask & ~hole
    if not known.any():
        return rgba.copy()
    rgb = np.ascontiguousarray(rgba[..., :3])
    outside = ~mask
    if outside.any():
        rgb = pyramid_fill(rgb, ~known)
        rgb[known] = rgba[..., :3][known]
    filled = draw_outline(rgb, mask, hole) if method == "outline" else inpaint(rgb, hole, method)
    out = rgba.copy()
    out[hole, :3] = filled[hole, :3]
    return out
