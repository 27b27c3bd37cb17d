"""Mask -> contours -> Douglas-Peucker -> constrained Delaunay, and group merging."""
import numpy as np
import pytest

from puppet.geom.contour import mask_regions, resample_ring, ring_area, simplify_ring, subdivide_segment
from puppet.geom.merge import merge_meshes
from puppet.geom.triangulate import signed_areas, triangulate_regions


def disc_mask(h=80, w=100, c=(50, 40), r=30, hole=0):
    yy, xx = np.mgrid[:h, :w] + 0.5
    d = np.hypot(xx - c[0], yy - c[1])
    return (d < r) & (d >= hole)


def test_rectangle_contour_encloses_every_pixel():
    m = np.zeros((20, 30), bool)
    m[5:15, 10:20] = True
    (reg,) = mask_regions(m, offset=(100, 200))
    P = reg.outer
    # pixel centres span 10.5..19.5; grown by one pixel -> 9.5..20.5, shifted by the offset
    assert P[:, 0].min() == pytest.approx(109.5) and P[:, 0].max() == pytest.approx(120.5)
    assert P[:, 1].min() == pytest.approx(204.5) and P[:, 1].max() == pytest.approx(215.5)
    assert reg.holes == []


@pytest.mark.parametrize("box", [(0, 0, 30, 20), (0, 5, 12, 20), (18, 0, 30, 9), (29, 19, 30, 20)])
def test_a_mask_at_the_image_edge_reaches_the_edge_and_covers_every_pixel_centre(box):
    """Where the mask meets the image's edge the ring lies on that edge (not through the
    edge pixels' centres, where the rasteriser's fill rule drops the last row and column:
    issue 32, 'the last row and column of every imported layer come out transparent'),
    and never beyond it (the texture has nothing there); the mesh covers every centre."""
    x0, y0, x1, y1 = box
    m = np.zeros((20, 30), bool)
    m[y0:y1, x0:x1] = True
    (reg,) = mask_regions(m, offset=(100, 200))
    P = reg.outer
    assert P[:, 0].min() >= 100 and P[:, 0].max() <= 130 and P[:, 1].min() >= 200 and P[:, 1].max() <= 220
    assert P[:, 0].min() == (100 if x0 == 0 else 99.5 + x0) and P[:, 0].max() == (130 if x1 == 30 else x1 + 100.5)
    assert P[:, 1].min() == (200 if y0 == 0 else 199.5 + y0) and P[:, 1].max() == (220 if y1 == 20 else y1 + 200.5)
    yy, xx = np.nonzero(m)
    c = np.stack([xx + 100.5, yy + 200.5], 1)  # every pixel centre of the mask
    A, B = P, np.roll(P, -1, axis=0)
    d = B - A
    t = np.clip((((c[:, None] - A[None]) * d[None]).sum(2)) / (d * d).sum(1)[None], 0, 1)
    gap = np.linalg.norm(c[:, None] - (A[None] + t[..., None] * d[None]), axis=2).min(axis=1)
    assert gap.min() > 0.3  # no centre on the outline (0.35 at cut corners): the fill rule cannot drop it
    up = (A[None, :, 1] > c[:, None, 1]) != (B[None, :, 1] > c[:, None, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x = A[None, :, 0] + (c[:, None, 1] - A[None, :, 1]) * d[None, :, 0] / d[None, :, 1]
    assert ((up & (x > c[:, None, 0])).sum(1) % 2 == 1).all()  # and every one inside it
    V = triangulate_regions([reg], max_area=4.0).V
    assert V[:, 0].min() >= 100 and V[:, 0].max() <= 130 and V[:, 1].min() >= 200 and V[:, 1].max() <= 220


def test_ring_keeps_its_hole_and_components_are_separate():
    m = disc_mask(r=30, hole=12)
    m[:, 95:] = True  # a second component along the right edge
    regs = mask_regions(m)
    assert len(regs) == 2
    ring = max(regs, key=lambda r: abs(ring_area(r.outer)))
    assert len(ring.holes) == 1
    M = triangulate_regions(regs, max_area=10.0)
    cent = M.V[M.F].mean(axis=1)
    # no triangle inside the hole
    assert (np.hypot(cent[:, 0] - 50, cent[:, 1] - 40) > 10.5).all()
    area = -signed_areas(M.V, M.F).sum() / 2
    assert area == pytest.approx(m.sum(), rel=0.08)


def test_douglas_peucker_keeps_corners_and_drops_collinear_points():
    sq = np.array([[0, 0], [5, 0], [10, 0], [10, 5], [10, 10], [5, 10], [0, 10], [0, 5]], float)
    S = simplify_ring(sq, 0.5)
    assert len(S) == 4
    assert {tuple(p) for p in S} == {(0, 0), (10, 0), (10, 10), (0, 10)}


def test_resample_and_subdivide_lengths():
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    R = resample_ring(sq, 3.0)
    L = np.linalg.norm(np.roll(R, -1, 0) - R, axis=1)
    assert L.max() <= 3.0 + 1e-12 and len(R) == 16
    S = subdivide_segment([0, 0], [7, 0], 2.0)
    assert len(S) == 5 and np.allclose(S[-1], [7, 0]) and np.allclose(np.diff(S[:, 0]), 1.75)


def test_triangulation_quality_orientation_pins_and_segments():
    regs = mask_regions(disc_mask())
    pins = np.array([[40.25, 33.5], [61.0, 47.75]])
    seg = subdivide_segment([35, 40], [65, 40], 4.0)
    M = triangulate_regions(regs, max_area=12.0, min_angle=25, points=pins, segments=[seg])
    A = signed_areas(M.V, M.F)
    assert (A < 0).all(), "counter-clockwise as seen on screen (y down) = negative raw area"
    assert (np.abs(A) / 2 <= 12.0 * 1.0001).all()
    for p in np.concatenate([pins, seg]):
        assert np.min(np.linalg.norm(M.V - p, axis=1)) == 0.0
    # the subdivided segment pieces are edges of the mesh
    E = {tuple(sorted(e)) for f in M.F for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    idx = [int(np.argmin(np.linalg.norm(M.V - q, axis=1))) for q in seg]
    for a, b in zip(idx, idx[1:]):
        assert tuple(sorted((a, b))) in E
    # min angle: Triangle aims for 25 degrees; allow the boundary's own small angles
    a, b, c = M.V[M.F[:, 0]], M.V[M.F[:, 1]], M.V[M.F[:, 2]]

    def ang(p, q, r):
        u, v = q - p, r - p
        return np.degrees(np.arccos(np.clip((u * v).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1), -1, 1)))
    mins = np.minimum(np.minimum(ang(a, b, c), ang(b, c, a)), ang(c, a, b))
    assert np.median(mins) > 35 and np.mean(mins < 20) < 0.02


def test_merge_shares_link_vertices():
    V1 = np.array([[0, 0], [1, 0], [0, 1]], float)
    V2 = np.array([[1, 0], [0, 1], [1, 1]], float)
    F = np.array([[0, 2, 1]])
    g = merge_meshes([(V1, F), (V2, F)], [(0, 1, 1, 0), (0, 2, 1, 1)])
    assert len(g.V) == 4
    assert np.allclose(g.V[g.maps[0]], V1) and np.allclose(g.V[g.maps[1]], V2)
    assert g.maps[0][1] == g.maps[1][0] and g.maps[0][2] == g.maps[1][1]
    assert len(g.F) == 2 and set(g.F.ravel()) == {0, 1, 2, 3}


def test_pinched_notch_does_not_crash_triangle(tmp_path):
    """Growing a mask can pinch a narrow notch into one-pixel holes whose rings touch the
    outer ring; Triangle used to segfault on them (Kenney hair). Run in a subprocess so a
    crash fails the test instead of killing the run."""
    import subprocess
    import sys
    from tests.conftest import ASSETS
    code = f"""
import numpy as np
from puppet.imaging.io import load_rgba
from puppet.geom.contour import mask_regions
from puppet.geom.triangulate import triangulate_regions
m = load_rgba({ASSETS + '/kenney-character/brown2Man5.png'!r})[..., 3] > 0
for min_hole in (16, 0):
    M = triangulate_regions(mask_regions(m, min_hole=min_hole), max_area=6.0)
    assert len(M.F) > 1000
print("ok")
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "ok", (r.returncode, r.stderr[-500:])


def test_small_holes_are_filled_big_ones_kept():
    from puppet.geom.contour import fill_small_holes
    m = np.ones((30, 30), np.uint8)
    m[5:7, 5:7] = 0      # 4 px hole
    m[15:25, 15:25] = 0  # 100 px hole
    out = fill_small_holes(m, 16)
    assert out[5:7, 5:7].all() and not out[15:25, 15:25].any()


def test_clean_pslg_merges_touching_rings():
    from puppet.geom.triangulate import clean_pslg
    P = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [4, 0], [5, 1], [4, 2]], float)
    S = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 4], [1, 1]])
    g = clean_pslg(P, S)
    assert len(g["vertices"]) == 6
    assert len(g["segments"]) == 7 and (g["segments"][:, 0] != g["segments"][:, 1]).all()
