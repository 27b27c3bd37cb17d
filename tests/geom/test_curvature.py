import numpy as np
import pytest

from puppet.geom.contour import mask_regions, ring_area
from puppet.geom.curvature import (
    contour_curvature,
    contour_length,
    contour_start,
    curvature_maxima,
    length_scale,
    resample_closed,
)


def circle(r=50.0, n=400, centre=(120.0, 90.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)]


def rounded_square(x0=20.0, y0=30.0, side=200.0, rho=10.0, per_arc=16):
    """Dense ring of a square with rounded corners, positive shoelace area (clockwise on
    screen), starting at the end of the top side; also the corners' arc midpoints."""
    x1, y1 = x0 + side, y0 + side
    centres = [(x1 - rho, y0 + rho), (x1 - rho, y1 - rho), (x0 + rho, y1 - rho), (x0 + rho, y0 + rho)]
    starts = [-np.pi / 2, 0.0, np.pi / 2, np.pi]  # top-right, bottom-right, bottom-left, top-left
    pts, mids = [], []
    for (cx, cy), a0 in zip(centres, starts):
        a = a0 + np.linspace(0, np.pi / 2, per_arc + 1)
        pts.append(np.c_[cx + rho * np.cos(a), cy + rho * np.sin(a)])
        mids.append([cx + rho * np.cos(a0 + np.pi / 4), cy + rho * np.sin(a0 + np.pi / 4)])
    return np.concatenate(pts), np.array(mids)


def star(n_tips=5, r_out=100.0, r_in=40.0, centre=(150.0, 150.0)):
    ang = np.pi / 2 + np.arange(2 * n_tips) * np.pi / n_tips
    rad = np.where(np.arange(2 * n_tips) % 2 == 0, r_out, r_in)
    return np.c_[centre[0] + rad * np.cos(ang), centre[1] - rad * np.sin(ang)]


# --- resampling --------------------------------------------------------------------------

def test_resample_closed_hand_checked_square():
    P = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    Q = resample_closed(P, 8)
    np.testing.assert_allclose(Q, [[0, 0], [2, 0], [4, 0], [4, 2], [4, 4], [2, 4], [0, 4], [0, 2]])


def test_resample_closed_is_uniform_and_on_the_ring():
    P = circle(n=37) + np.random.default_rng(1).normal(scale=0.01, size=(37, 2))
    P = np.r_[P, P[:1]]  # an explicitly closed ring is accepted
    Q = resample_closed(P, 500)
    assert Q.shape == (500, 2)
    np.testing.assert_array_equal(Q[0], P[0])
    steps = np.linalg.norm(np.roll(Q, -1, 0) - Q, axis=1)
    assert steps.max() / steps.min() < 1.01  # chords of equal arcs: equal within a bend
    assert contour_length(Q) == pytest.approx(contour_length(P), rel=1e-3)


def test_resample_closed_skips_repeated_points():
    P = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    np.testing.assert_allclose(resample_closed(P, 4), [[0, 0], [4, 0], [4, 4], [0, 4]])


# --- curvature ---------------------------------------------------------------------------

@pytest.mark.parametrize("r", [5.0, 50.0, 400.0])
def test_circle_has_curvature_one_over_r_everywhere(r):
    P = resample_closed(circle(r=r, n=200), 1024)
    kappa = contour_curvature(P, sigma=0.1 * r)
    assert np.all(np.abs(kappa * r - 1.0) < 0.02)
    # the smoothed circle shrinks by exp(-sigma^2 / 2r^2): the closed form, exactly
    np.testing.assert_allclose(contour_curvature(P, sigma=0.5 * r) * r, np.exp(0.125), rtol=1e-3)


def test_curvature_sign_follows_orientation():
    P = resample_closed(circle(), 512)
    assert ring_area(P) > 0
    assert np.all(contour_curvature(P, 5.0) > 0)
    assert np.all(contour_curvature(P[::-1], 5.0) < 0)


def test_curvature_of_a_sharp_corner_in_closed_form():
    P = resample_closed(np.array([[0.0, 0.0], [400.0, 0.0], [400.0, 400.0], [0.0, 400.0]]), 1600)
    sigma = 8.0
    kappa = contour_curvature(P, sigma)
    # corner turning by theta between long sides: tangent (1 - Phi) t1 + Phi t2, so at
    # the corner x' = (t1 + t2) / 2 and x' x x'' = g(0) sin(theta)
    g0 = 1.0 / (sigma * np.sqrt(2 * np.pi))
    theta = np.pi / 2
    assert kappa[400] == pytest.approx(g0 * np.sin(theta) / np.cos(theta / 2) ** 3, rel=3e-3)
    assert abs(kappa[200]) < 1e-9  # middle of a side: straight
    assert np.argmax(kappa[200:600]) == 200


# --- maxima ------------------------------------------------------------------------------

def test_circle_has_no_curvature_maxima():
    for beta in (0.5, 1, 2, 4, 8, 16):
        assert len(curvature_maxima(circle(n=720), beta=beta)) == 0


@pytest.mark.parametrize("beta", [1.0, 4.0, 16.0])
def test_rounded_square_maxima_at_the_corners_in_contour_order(beta):
    P, mids = rounded_square()
    idx = curvature_maxima(P, beta=beta)
    assert len(idx) == 4
    # start: the topmost-leftmost point (start of the top side); walking rightward, the
    # corners come top-right, bottom-right, bottom-left, top-left
    np.testing.assert_allclose(P[idx], mids, atol=3.0)


def test_order_does_not_depend_on_how_the_ring_is_given():
    P, mids = rounded_square()
    expected = P[curvature_maxima(P, beta=4)]
    for Q in (np.roll(P, 17, axis=0), P[::-1], np.roll(P[::-1], 5, axis=0)):
        np.testing.assert_array_equal(Q[curvature_maxima(Q, beta=4)], expected)
    assert contour_start(np.roll(P, 17, axis=0)) == (contour_start(P) + 17) % len(P)
    np.testing.assert_allclose(P[contour_start(P)], [30.0, 30.0])


def test_star_maxima_at_its_corners_and_more_points_for_larger_beta():
    S = star()
    counts = [len(curvature_maxima(S, beta=b)) for b in (1, 2, 4, 8, 16)]
    assert counts == sorted(counts) and counts[0] < counts[-1]
    idx = curvature_maxima(S, beta=8)
    assert len(idx) == 10  # 5 tips and 5 notches: every corner, each exactly once
    # from the top tip (topmost point) clockwise on screen: tip, notch, tip, ... i.e. the
    # star's vertices in decreasing index order (the star is listed counter-clockwise)
    np.testing.assert_array_equal(idx, [0, 9, 8, 7, 6, 5, 4, 3, 2, 1])
    tips = curvature_maxima(S, beta=2)
    np.testing.assert_array_equal(tips, [0, 8, 6, 4, 2])  # coarser: the five tips only


def test_sigma_is_length_scale_over_beta():
    S = star()
    assert length_scale(S) == pytest.approx(contour_length(S) / (2 * np.pi))
    _, Q, kappa = curvature_maxima(S, beta=3, return_curvature=True)
    np.testing.assert_allclose(kappa, contour_curvature(Q, length_scale(S) / 3))


def test_maxima_on_pixel_contours_ignore_the_staircase():
    import cv2

    corners = np.array([[160, 135], [65, 160], [39, 65], [135, 39]], np.int32)  # 30 deg square
    mask = np.zeros((200, 200), np.uint8)
    cv2.fillPoly(mask, [corners], 1)
    (reg,) = mask_regions(mask.astype(bool))
    for beta in (4, 16):
        idx = curvature_maxima(reg.outer, beta=beta)
        # from the topmost corner, clockwise on screen; the contour is grown by 1 px
        np.testing.assert_allclose(reg.outer[idx], corners[[3, 0, 1, 2]], atol=3.0)
    yy, xx = np.mgrid[:200, :200]
    (disc,) = mask_regions((xx - 100) ** 2 + (yy - 100) ** 2 < 60**2)
    assert all(len(curvature_maxima(disc.outer, beta=b)) == 0 for b in (1, 2, 4, 8, 16))


def test_maxima_are_scale_invariant():
    P, _ = rounded_square()
    np.testing.assert_array_equal(curvature_maxima(3.0 * P, beta=4), curvature_maxima(P, beta=4))
    S = star()
    for beta in (2, 8):
        expected = curvature_maxima(S, beta=beta)
        for scale in (0.05, 20.0):
            np.testing.assert_array_equal(curvature_maxima(scale * S, beta=beta), expected)


def test_bad_input():
    with pytest.raises(ValueError):
        curvature_maxima(circle(), beta=0)
    with pytest.raises(ValueError):
        resample_closed(np.array([[0.0, 0.0], [1.0, 1.0]]), 10)
    with pytest.raises(ValueError):
        contour_curvature(circle(), sigma=-1)
