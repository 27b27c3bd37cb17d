"""Small meshes and helpers shared by the deformer tests."""
import numpy as np
import triangle


def triangulate(pts, max_area):
    """Quality triangulation of a simple polygon: V (n, 2), F (m, 3) int64."""
    n = len(pts)
    seg = np.c_[np.arange(n), (np.arange(n) + 1) % n]
    T = triangle.triangulate({"vertices": np.asarray(pts, float), "segments": seg}, f"pq30a{max_area}")
    return T["vertices"], T["triangles"].astype(np.int64)


def rectangle(w, h, max_area):
    return triangulate([[0, 0], [w, 0], [w, h], [0, h]], max_area)


def l_shape(max_area=2.0):
    return triangulate([[0, 0], [20, 0], [20, 8], [8, 8], [8, 20], [0, 20]], max_area)


def rot(theta):
    """2x2 rotation matrix (raw axes)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def nearest(V, pts):
    """Index of the vertex nearest to each point."""
    return np.array([np.argmin(np.linalg.norm(V - p, axis=1)) for p in pts])
