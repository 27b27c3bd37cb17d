"""SIFT key points, ratio-test matches, RANSAC motion groups, and a point carried by its key-point triangle.

The building blocks of :mod:`puppet.video.track` (Shen, Ma and Liu 2010, "An MLS-based cartoon
deformation", §4): key points are matched between two frames, outliers are dropped by a sequence
of RANSAC similarity fits (one per rigidly moving part), the inliers of the first frame are
triangulated (Delaunay) and a point is carried to the second frame by the affine map of the
triangle that contains it (eq. 17-19), or, outside the triangulation, by a weighted similarity
fitted to its nearest matches.

Coordinates are OpenCV's: pixel ``(i, j)`` has its centre at ``x = j, y = i``.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass
class Features:
    """Key points of one frame.

    Attributes
    ----------
    pts : (n, 2) float64 array
        Positions in frame pixels.
    desc : (n, 128) float32 array
        SIFT descriptors.
    """

    pts: np.ndarray
    desc: np.ndarray

    def __len__(self) -> int:
        return len(self.pts)


def empty_features() -> Features:
    return Features(np.zeros((0, 2)), np.zeros((0, 128), np.float32))


class Detector:
    """SIFT on a (possibly downscaled) grey frame, restricted to a mask's bounding box.

    Parameters
    ----------
    scale : float
        The frame is resized by this factor before detection (OpenCV's SIFT doubles its input
        internally, so 0.5 still localises key points at about full-resolution precision and
        runs about 4x faster). Positions are mapped back to full-frame pixels.
    contrast : float
        SIFT ``contrastThreshold``: flat-coloured cartoon frames need a lower one than photos.
    layers : int
        SIFT ``nOctaveLayers``. OpenCV pre-filters extrema with ``int(0.5 * contrast / layers * 255)``:
        below 1 every pixel becomes a candidate and detection is 3x slower (2 layers with
        ``contrast=0.02`` keep it at 1).
    dilate : int
        The mask is grown by this many pixels so that corners on the outline count.
    """

    def __init__(self, *, scale: float = 0.5, contrast: float = 0.02, layers: int = 2, dilate: int = 4):
        self.scale = float(scale)
        self.dilate = int(dilate)
        self.sift = cv2.SIFT_create(nOctaveLayers=layers, contrastThreshold=contrast)

    def __call__(self, gray: np.ndarray, mask: np.ndarray | None = None) -> Features:
        """Key points of ``gray`` ((H, W) uint8) inside ``mask`` ((H, W) bool or None)."""
        x0, y0 = 0, 0
        m8 = None
        if mask is not None:
            m = np.asarray(mask, bool)
            if not m.any():
                return empty_features()
            if self.dilate > 0:
                k = 2 * self.dilate + 1
                m = cv2.dilate(m.astype(np.uint8), np.ones((k, k), np.uint8)) > 0
            ys, xs = np.nonzero(m.any(axis=1))[0], np.nonzero(m.any(axis=0))[0]
            pad = 16
            y0, y1 = max(ys[0] - pad, 0), min(ys[-1] + pad + 1, gray.shape[0])
            x0, x1 = max(xs[0] - pad, 0), min(xs[-1] + pad + 1, gray.shape[1])
            gray = gray[y0:y1, x0:x1]
            m8 = m[y0:y1, x0:x1].astype(np.uint8) * 255
        s = self.scale
        if s != 1.0:
            h, w = gray.shape
            size = (max(int(round(w * s)), 1), max(int(round(h * s)), 1))
            sx, sy = size[0] / w, size[1] / h
            gray = cv2.resize(gray, size, interpolation=cv2.INTER_AREA)
            if m8 is not None:
                m8 = cv2.resize(m8, size, interpolation=cv2.INTER_NEAREST)
        else:
            sx = sy = 1.0
        kp, desc = self.sift.detectAndCompute(gray, m8)
        if desc is None or not kp:
            return empty_features()
        pts = np.array([k.pt for k in kp], np.float64)
        # pixel centre j of the small image covers [j, j+1) / s of the large one
        pts[:, 0] = (pts[:, 0] + 0.5) / sx - 0.5 + x0
        pts[:, 1] = (pts[:, 1] + 0.5) / sy - 0.5 + y0
        return Features(pts, desc)


def match(a: Features, b: Features, *, ratio: float = 0.8) -> tuple[np.ndarray, np.ndarray]:
    """Ratio-test (Lowe) matches from ``a`` to ``b``, each key point of ``b`` used at most once.

    Returns
    -------
    ia, ib : (m,) int arrays
        ``a.pts[ia[k]]`` matches ``b.pts[ib[k]]``.
    """
    none = np.zeros(0, int)
    if len(a) == 0 or len(b) < 2:
        return none, none
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(a.desc, b.desc, k=2)
    ia, ib, dist = [], [], []
    for pair in knn:
        if len(pair) == 2 and pair[0].distance < ratio * pair[1].distance:
            ia.append(pair[0].queryIdx)
            ib.append(pair[0].trainIdx)
            dist.append(pair[0].distance)
    if not ia:
        return none, none
    ia, ib, dist = np.array(ia), np.array(ib), np.array(dist)
    order = np.argsort(dist, kind="stable")
    _, first = np.unique(ib[order], return_index=True)
    keep = np.sort(order[first])
    return ia[keep], ib[keep]


def motion_groups(src: np.ndarray, dst: np.ndarray, *, threshold: float = 2.5, min_inliers: int = 4,
                  max_groups: int = 6) -> np.ndarray:
    """Split matches into rigidly moving groups by repeated RANSAC similarity fits.

    Parameters
    ----------
    src, dst : (n, 2) float arrays
        Matched positions in the two frames.
    threshold : float
        RANSAC reprojection threshold in pixels.
    min_inliers : int
        A fit with fewer inliers ends the search.

    Returns
    -------
    (n,) int array
        Group of each match (0 = the largest), -1 for outliers.
    """
    n = len(src)
    labels = np.full(n, -1)
    rest = np.arange(n)
    for g in range(max_groups):
        if len(rest) < max(min_inliers, 2):
            break
        M, inl = cv2.estimateAffinePartial2D(src[rest], dst[rest], method=cv2.RANSAC,
                                             ransacReprojThreshold=threshold, maxIters=200,
                                             confidence=0.995, refineIters=5)
        if M is None or inl is None:
            break
        inl = inl.ravel().astype(bool)
        if inl.sum() < min_inliers:
            break
        labels[rest[inl]] = g
        rest = rest[~inl]
    return labels


def similarity_fit(src: np.ndarray, dst: np.ndarray, w: np.ndarray) -> tuple[complex, np.ndarray, np.ndarray]:
    """Weighted least-squares similarity ``y = mu_y + c (x - mu_x)`` in complex form.

    Parameters
    ----------
    src, dst : (n, 2) float arrays
    w : (n,) float array of positive weights

    Returns
    -------
    c : complex
        Scaled rotation (``0`` for a single point: a pure translation is then ``c = 1``).
    mu_x, mu_y : (2,) float arrays
        Weighted centroids.
    """
    w = w / w.sum()
    mu_x, mu_y = w @ src, w @ dst
    X = (src - mu_x) @ np.array([1, 1j])
    Y = (dst - mu_y) @ np.array([1, 1j])
    s2 = float(w @ (X.real ** 2 + X.imag ** 2))
    c = complex(w @ (np.conj(X) * Y)) / s2 if s2 > 1e-9 else 1.0 + 0j
    return c, mu_x, mu_y


def apply_similarity(c: complex, mu_x: np.ndarray, mu_y: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Apply the result of :func:`similarity_fit` to points ``p`` ((k, 2))."""
    z = c * ((p - mu_x) @ np.array([1, 1j]))
    return mu_y + np.stack([z.real, z.imag], axis=-1)
