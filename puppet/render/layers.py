"""What the compositor draws: one textured, deformed mesh per layer, and the numpy
helpers that prepare it (premultiplied textures, depth range, triangle classes, edges)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.geom.mesh import edges

#: Fragments whose premultiplied texture alpha is below this are discarded.
ALPHA_MIN = 0.5 / 255.0
#: Fragments whose texture alpha is at least this are opaque: they write depth and hide
#: everything behind them (an alpha that rounds to 255).
ALPHA_OPAQUE = 254.5 / 255.0
#: Window-depth step per list position: exact depth ties between layers go to the later one.
TIE_BIAS = 2.0 ** -16
#: Window depths are clamped to [Z_MIN, Z_MAX] (inside the depth buffer's clear value 1).
Z_MIN = 2.0 ** -16
Z_MAX = 1.0 - 2.0 ** -16


@dataclass
class DrawLayer:
    """One textured mesh to composite.

    Attributes
    ----------
    key : str
        Stable name; the uploaded texture and buffers are cached under it across frames.
    image : ndarray, shape (h, w, 4), uint8
        Straight-alpha RGBA texture. Treat it as immutable: the texture is re-uploaded
        only when a different array (or shape) is passed under the same key.
    offset : tuple of float
        Canvas position of the image's top-left corner.
    rest : ndarray, shape (n, 2)
        Rest positions, canvas pixels: texture coordinate = (rest - offset) / (w, h).
    deformed : ndarray, shape (n, 2)
        Drawn positions, canvas pixels (x right, y down, origin top-left).
    triangles : ndarray, shape (m, 3), int
        Vertex indices. Their order matters only for exact depth ties inside the layer
        (the later triangle is in front, see :mod:`puppet.render.compositor`).
    depth : ndarray, shape (n,)
        Per-vertex depth, higher = in front, any real range.
    classes : (ndarray, ndarray) or None
        ``(edge, empty)`` as :func:`classify_triangles` gives them for this image, rest
        mesh and offset (see :func:`texture_uv`), kept by the caller (a scene keeps them
        in its cache: ~13 ms a layer of the 4K PSD); None: computed on upload.
    """

    key: str
    image: np.ndarray
    offset: tuple[float, float]
    rest: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    depth: np.ndarray
    classes: tuple[np.ndarray, np.ndarray] | None = None


def premultiply(image: np.ndarray) -> np.ndarray:
    """Premultiply straight RGBA uint8, rounding to nearest: ``round(c * a / 255)``.

    OpenCV's RGBA -> mRGBA conversion gives exactly that (checked on all 65 536 pairs in
    the tests) and runs ~3x faster than its saturating multiply with scale 1/255 (4 against
    13 ms at 1000x1500), itself ~6x faster than the integer formula in numpy; it counts at
    start-up: the 4K PSD scene has 20 layer images of 114 MB in all.
    """
    import cv2  # the meshing has loaded it already on every path that draws

    return cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGBA2mRGBA)


def unpremultiply_soft(frame: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA uint8 ``frame`` (h, w, 4) made straight in place, as the
    ``straight`` shader does (``min(round(c * 255 / a), 255)``), touching only the pixels
    with 0 < alpha < 255 (a drag preview's soft edges: few); returns ``frame``."""
    flat = frame.reshape(-1, 4)
    soft = np.flatnonzero(flat[:, 3] - np.uint8(1) < 254)  # 0 < a < 255 (a = 0 wraps to 255)
    if len(soft):
        px = flat[soft].astype(np.float64)
        flat[soft, :3] = np.minimum(np.rint(px[:, :3] * 255.0 / px[:, 3:]), 255.0)
    return frame


def depth_window(lo: float, hi: float) -> tuple[float, float]:
    """Uniforms ``(hi', 1 / (hi' - lo'))`` mapping depth d to window depth
    ``(hi' - d) / (hi' - lo')`` (0 = nearest), the range widened by max(5 %, 0.5) a side.

    The layer at list position i is then moved ``i * TIE_BIAS`` nearer and the result
    clamped to [Z_MIN, Z_MAX] (in the vertex shader).
    """
    margin = max(0.05 * (hi - lo), 0.5)
    lo, hi = lo - margin, hi + margin
    return hi, 1.0 / (hi - lo)


def texture_uv(rest: np.ndarray, offset, shape) -> np.ndarray:
    """Texture coordinates (n, 2) float32 of rest positions on an image of ``shape``
    (h, w, ...) whose top-left corner sits at canvas ``offset``."""
    h, w = shape[:2]
    return ((np.asarray(rest, np.float64) - tuple(float(v) for v in offset)) / (w, h)).astype(np.float32)


def classify_triangles(image: np.ndarray, uv: np.ndarray, triangles: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Which triangles can give translucent fragments, and which give none at all.

    A fragment samples the texture bilinearly (clamp to edge) at a point of its rest
    triangle, so it reads only texels within one texel of that triangle's bounding box.
    A triangle whose reach holds only alpha-255 texels gives opaque fragments only.

    Parameters
    ----------
    image : ndarray, shape (h, w, 4), uint8
    uv : ndarray, shape (n, 2)
        Texture coordinates in 0..1 (texel i spans [i / w, (i + 1) / w]).
    triangles : ndarray, shape (m, 3), int

    Returns
    -------
    edge : ndarray, shape (m,), bool
        Some texel in reach has alpha < 255: the triangle is drawn in the edge pass.
    empty : ndarray, shape (m,), bool
        Every texel in reach has alpha 0: the triangle draws nothing and is skipped.
    """
    h, w = image.shape[:2]
    alpha = image[..., 3]
    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    if not len(tri):
        return np.zeros(0, bool), np.zeros(0, bool)
    corners = np.asarray(uv, np.float64)[tri] * (w, h)  # (m, 3, 2) texel units
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]  # (elementwise: numpy's reduce over an axis of 3 is slow)
    lo = np.floor(np.minimum(np.minimum(a, b), c) - 0.5 - 1e-3).astype(np.int64)
    hi = np.floor(np.maximum(np.maximum(a, b), c) - 0.5 + 1e-3).astype(np.int64) + 1
    x0, x1 = np.clip(lo[:, 0], 0, w - 1), np.clip(hi[:, 0], 0, w - 1) + 1
    y0, y1 = np.clip(lo[:, 1], 0, h - 1), np.clip(hi[:, 1], 0, h - 1) + 1

    import cv2

    def box_counts(mask: np.ndarray) -> np.ndarray:
        table = cv2.integral(mask.view(np.uint8), sdepth=cv2.CV_32S)  # (h + 1, w + 1) summed areas
        return table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]

    empty = box_counts(alpha > 0) == 0
    edge = (box_counts(alpha < 255) > 0) & ~empty
    return edge, empty


def fragment_bound(deformed: np.ndarray, triangles: np.ndarray, scale: tuple[float, float]
                   ) -> float:
    """Upper bound of the fragments (pixel centres) the triangles cover at ``scale``:
    the sum of area + perimeter + 1 per triangle, in output pixels."""
    if not len(triangles):
        return 0.0
    p = np.asarray(deformed, np.float64)[np.asarray(triangles, np.int64)] * scale
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    perimeter = (np.linalg.norm(b - a, axis=1) + np.linalg.norm(c - b, axis=1)
                 + np.linalg.norm(a - c, axis=1))
    return float(np.sum(area + perimeter + 1.0))


def mesh_edges(triangles: np.ndarray) -> np.ndarray:
    """Unique undirected edges of triangles (m, 3) as GL indices, shape (k, 2) int32
    (:func:`puppet.geom.mesh.edges`, the one home of the primitive)."""
    return edges(triangles).astype(np.int32)


def check_background(background) -> np.ndarray:
    """Background as an (H, W, 4) uint8 image; a colour becomes a 1x1 image."""
    if isinstance(background, np.ndarray) and background.ndim == 3:
        if background.shape[2] != 4 or background.dtype != np.uint8:
            raise ValueError("a background image must be (H, W, 4) uint8")
        return background
    rgba = np.asarray(background, np.float64).reshape(-1)
    if rgba.shape != (4,) or not np.all((rgba >= 0) & (rgba <= 255)):
        raise ValueError(f"background colour must be 4 values in 0..255, got {background}")
    return np.rint(rgba).astype(np.uint8).reshape(1, 1, 4)


def check_layer(layer: DrawLayer) -> None:
    """Raise ValueError naming the layer when its arrays do not fit together."""
    img, n, tri = layer.image, len(layer.deformed), np.asarray(layer.triangles)
    problem = (
        "image must be (h, w, 4) uint8" if img.ndim != 3 or img.shape[2] != 4
        or img.dtype != np.uint8 else
        "rest, deformed (n, 2) and depth (n,) must agree" if np.shape(layer.rest) != (n, 2)
        or np.shape(layer.deformed) != (n, 2) or np.shape(layer.depth) != (n,) else
        f"triangles must be (m, 3) indices below {n}" if tri.ndim != 2 or tri.shape[1] != 3
        or (tri.size and (tri.min() < 0 or tri.max() >= n)) else
        "depth and deformed must be finite" if not (np.all(np.isfinite(layer.depth))
                                                  and np.all(np.isfinite(layer.deformed))) else
        f"classes must be two ({len(tri)},) bool arrays" if layer.classes is not None
        and not classes_fit(layer.classes, len(tri))
        else None)
    if problem:
        raise ValueError(f"layer {layer.key!r}: {problem}")


def classes_fit(classes, m: int) -> bool:
    """Are ``classes`` an ``(edge, empty)`` pair of (m,) bool arrays?"""
    return (isinstance(classes, tuple) and len(classes) == 2
            and all(isinstance(c, np.ndarray) and c.dtype == bool and c.shape == (m,) for c in classes))


def check_vertices(key: str, n: int, deformed, depth) -> tuple[np.ndarray | None,
                                                                np.ndarray | None]:
    """Validate an update of an uploaded layer's n vertices; float arrays or None."""
    out = []
    for name, value, shape in (("deformed", deformed, (n, 2)), ("depth", depth, (n,))):
        if value is None:
            out.append(None)
            continue
        arr = np.asarray(value, np.float64)
        if arr.shape != shape or not np.all(np.isfinite(arr)):
            raise ValueError(f"layer {key!r}: {name} must be finite, shape {shape}, "
                             f"got {arr.shape}")
        out.append(arr)
    return out[0], out[1]
