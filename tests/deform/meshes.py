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


def two_squares():
    """Two squares meeting at a hinge of two vertices at (10, 0) (a link of strength < 1):
    V, parts, the pins' rest points P and targets bc, distances D from the pins and DH
    from the hinge's two sides."""
    V = np.array([[0, 0], [10, 0], [0, 10], [20, 0], [20, 10.0], [10, 0]])
    parts = [np.array([0, 1, 2]), np.array([5, 3, 4])]
    P = V[[0, 2, 3]]
    bc = np.array([[0, 0], [0, 10], [10, -10.0]])
    D = np.linalg.norm(V[None] - P[:, None], axis=2)
    DH = np.linalg.norm(V[None] - V[[1, 5]][:, None], axis=2)[None]
    return V, parts, P, bc, D, DH
