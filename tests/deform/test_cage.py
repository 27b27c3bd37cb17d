"""Cage coordinates: hand-computed cases, boundary points, affine/similarity precision,
conformality, landmark fitting, checks and automatic cages (puppet.deform.cage)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import triangle
from PIL import Image

from puppet.deform import cage
from puppet.deform.cage import (KINDS, CageFit, CageMap, auto_cage, check_cage, check_encloses, fit_cage, green, harmonic,
                                mvc, winding)
from puppet.deform.interp import jacobians
from puppet.geom.contour import mask_regions
from puppet.geom.mvc import mean_value_coordinates
from puppet.geom.triangulate import signed_areas, triangulate_regions

ASSETS = Path(__file__).resolve().parents[2] / "assets"

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
# an arrow pointing right with a deep notch on the left: from the lower arm the vertex
# (0, 100) lies behind the notch, so its mean value coordinate is negative there
ARROW = np.array([[0.0, 0.0], [60.0, 0.0], [100.0, 50.0], [60.0, 100.0], [0.0, 100.0], [50.0, 50.0]])


def outward_normals(C):
    E = np.roll(C, -1, axis=0) - C
    N = np.c_[E[:, 1], -E[:, 0]] / np.hypot(E[:, 0], E[:, 1])[:, None]
    return N if ((C[:, 0] * np.roll(C[:, 1], -1) - np.roll(C[:, 0], -1) * C[:, 1]).sum() > 0) else -N


def ellipse_cage(m=16, rx=100.0, ry=80.0, centre=(0.0, 0.0), jitter=0.0, seed=0):
    t = np.linspace(0.0, 2.0 * np.pi, m, endpoint=False)
    r = 1.0 + jitter * np.random.default_rng(seed).random(m)
    return np.c_[rx * r * np.cos(t), ry * r * np.sin(t)] + centre


def inner_mesh(C, shrink=0.97, area=30.0):
    m = len(C)
    T = triangle.triangulate({"vertices": C * shrink, "segments": np.c_[np.arange(m), (np.arange(m) + 1) % m]},
                             f"pq30a{area}Q")
    return T["vertices"], T["triangles"].astype(np.int64)


def turn(a):
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def test_square_hand_values():
    # mvc: the centre gets 1/4 each; a point on an edge its linear weights; a vertex itself
    W = mvc(SQUARE, [[0.5, 0.5], [0.25, 0.0], [1.0, 1.0], [2.0, 3.0]])
    np.testing.assert_allclose(W[0], 0.25, atol=1e-15)
    np.testing.assert_array_equal(W[1], [0.75, 0.25, 0.0, 0.0])
    np.testing.assert_array_equal(W[2], [0.0, 0.0, 1.0, 0.0])
    np.testing.assert_allclose(W[3] @ SQUARE, [2.0, 3.0], atol=1e-12)  # outside: still affine-precise
    # green at the centre: phi 1/4 by symmetry; psi = -int log|xi - x| / (2 pi) over an edge
    # at distance 1/2: (2 - pi/2 + ln 2) / (4 pi)
    phi, psi = green(SQUARE, [[0.5, 0.5]])
    np.testing.assert_allclose(phi, 0.25, atol=1e-15)
    np.testing.assert_allclose(psi, (2.0 - np.pi / 2.0 + np.log(2.0)) / (4.0 * np.pi), rtol=1e-13)


def test_mvc_against_the_existing_implementation_and_concave_negative():
    rng = np.random.default_rng(3)
    X = rng.random((200, 2)) * [100.0, 100.0]
    X = X[np.abs(winding(ARROW, X)) > 0.5]
    W = mvc(ARROW, X)
    np.testing.assert_allclose(W, mean_value_coordinates(ARROW, X), atol=1e-12)
    np.testing.assert_allclose(W.sum(axis=1), 1.0, atol=1e-13)
    np.testing.assert_allclose(W @ ARROW, X, atol=1e-10)
    # seen from (30, 10), in the lower arm, the vertex (0, 100) hides behind the notch
    w = mvc(ARROW, [[30.0, 10.0], [35.0, 25.0]])
    assert (w[:, 4] < 0).all()
    h = harmonic(ARROW, [[30.0, 10.0], [35.0, 25.0]])  # harmonic coordinates stay non-negative
    assert h.min() >= 0 and np.abs(h.sum(axis=1) - 1.0).max() < 1e-12


def test_green_closed_form_matches_quadrature_and_boundary_limit():
    C = ARROW
    X = np.array([[30.0, 20.0], [75.0, 50.0], [55.0, 90.0]])
    phi, psi = green(C, X)
    N = outward_normals(C)
    g, gw = np.polynomial.legendre.leggauss(400)
    s, sw = (g + 1.0) / 2.0, gw / 2.0
    for x, ph, ps in zip(X, phi, psi):
        qphi, qpsi = np.zeros(len(C)), np.zeros(len(C))
        for k in range(len(C)):
            p0, p1 = C[k], C[(k + 1) % len(C)]
            L = np.hypot(*(p1 - p0))
            xi = p0 + s[:, None] * (p1 - p0)
            d = xi - x
            r2 = (d * d).sum(axis=1)
            dG = (d @ N[k]) / r2 / (2.0 * np.pi)
            qphi[k] += L * sw @ ((1.0 - s) * dG)
            qphi[(k + 1) % len(C)] += L * sw @ (s * dG)
            qpsi[k] = -L * sw @ (np.log(r2) / (4.0 * np.pi))
        np.testing.assert_allclose(ph, qphi, atol=1e-9)
        np.testing.assert_allclose(ps, qpsi, atol=1e-9)
        np.testing.assert_allclose(ph @ C + ps @ N, x, atol=1e-10)
        assert abs(ph.sum() - 1.0) < 1e-13
    # on the cage: the limit from inside (an edge's point, a convex and a reflex vertex)
    B = np.array([[30.0, 0.0], [60.0, 0.0], [50.0, 50.0], [80.0, 25.0]])
    inward = np.array([[0.0, 1e-6], [-1e-6, 1e-7], [1e-6, 0.0], [-1e-6, 0.0]])  # beyond the snapping tolerance
    pb, sb = green(C, B)
    pi, si = green(C, B + inward)
    np.testing.assert_allclose(pb, pi, atol=1e-6)
    np.testing.assert_allclose(sb, si, atol=1e-6)
    np.testing.assert_allclose(green(C, B + inward / 100.0)[0], pb, atol=1e-9)  # within it: on the cage
    np.testing.assert_allclose(pb @ C + sb @ N, B, atol=1e-10)
    with pytest.raises(ValueError, match="outside"):
        green(C, [[10.0, 50.0]])


def test_precision_each_kind():
    C = ellipse_cage(20, jitter=0.3, centre=(300.0, 200.0))
    V, _ = inner_mesh(C - [300.0, 200.0], shrink=0.9, area=60.0)
    X = V + [300.0, 200.0]
    affine = np.array([[1.3, 0.4], [-0.2, 0.7]])
    sim = 1.25 * turn(0.6)
    for kind in KINDS:
        cm = CageMap(C, X, kind)
        np.testing.assert_allclose(cm.apply(C), X, atol=1e-9)  # the rest cage gives the rest points
        err_sim = np.abs(cm.apply(C @ sim.T + [15.0, -40.0]) - (X @ sim.T + [15.0, -40.0])).max()
        err_aff = np.abs(cm.apply(C @ affine.T + [3.0, 4.0]) - (X @ affine.T + [3.0, 4.0])).max()
        assert err_sim <= 0.1
        if kind == "green":
            assert err_aff > 1.0  # conformal, so not affine-precise
        else:
            assert err_aff <= 0.1
        U = cm.W @ cm.stacked(C)  # apply is the one product
        np.testing.assert_array_equal(U, cm.apply(C))
        np.testing.assert_allclose((cm.operator() @ np.r_[C[:, 0], C[:, 1]]).reshape(2, -1).T, X, atol=1e-9)
        # either orientation of the cage gives the same map
        np.testing.assert_allclose(CageMap(C[::-1], X, kind).apply((C @ sim.T)[::-1]), X @ sim.T, atol=1e-8)
    with pytest.raises(ValueError, match="kind"):
        CageMap(C, X, "bogus")
    assert CageMap(C, np.zeros((0, 2)), "green").apply(C).shape == (0, 2)
    with pytest.raises(ValueError, match="20 points"):
        CageMap(C, X, "mvc").apply(C[:-1])
    with pytest.raises(ValueError, match="outside"):
        harmonic(C, [[0.0, 0.0]])


def test_blocks_of_points_give_the_same_rows(monkeypatch):
    C = ellipse_cage(12, jitter=0.2)
    X = np.random.default_rng(5).random((300, 2)) * 100.0 - 50.0
    whole = mvc(C, X), green(C, X)
    monkeypatch.setattr(cage, "_CHUNK", 64)
    np.testing.assert_array_equal(mvc(C, X), whole[0])
    for a, b in zip(green(C, X), whole[1]):
        np.testing.assert_array_equal(a, b)


def test_conformality_of_a_stretch():
    C = ellipse_cage(16, 100.0, 80.0)
    V, F = inner_mesh(C, shrink=0.98, area=30.0)
    cen = V[F].mean(axis=1)
    P0, P1 = C, np.roll(C, -1, axis=0)
    d, e = cen[:, None] - P0[None], (P1 - P0)[None]
    t = np.clip((d * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
    dist = np.hypot(*(d - t[..., None] * e).transpose(2, 0, 1)).min(axis=1)
    far = dist > 0.1 * 200.0
    assert far.sum() > 200
    stretched = C * [1.3, 1.0]
    anis = {}
    for kind in ("green", "mvc"):
        s = np.linalg.svd(jacobians(V, F, CageMap(C, V, kind).apply(stretched)), compute_uv=False)
        anis[kind] = (s[:, 0] / s[:, 1])[far].mean()
    assert anis["green"] <= 1.05
    assert abs(anis["mvc"] - 1.3) < 0.02


def test_landmark_fitting():
    C = ellipse_cage(20, 100.0, 140.0, centre=(300.0, 300.0))
    V, F = inner_mesh(C - [300.0, 300.0], shrink=0.9, area=150.0)
    V = V + [300.0, 300.0]
    pins = np.array([[260.0, 200.0], [340.0, 200.0], [300.0, 300.0], [250.0, 400.0], [350.0, 400.0],
                     [300.0, 350.0]])
    sim = 1.2 * turn(0.4)
    rng = np.random.default_rng(1)
    poses = {  # garment fits: 25 % narrower, flared towards the hem, a few px each way
        "narrow": lambda p: np.c_[300.0 + 0.75 * (p[:, 0] - 300.0), p[:, 1]],
        "flare": lambda p: np.c_[300.0 + (p[:, 0] - 300.0) * (1.0 + 0.003 * (p[:, 1] - 200.0)), p[:, 1]],
        "jitter": lambda p: p + rng.normal(0.0, 3.0, p.shape),
    }
    for kind in KINDS:
        fit, mesh_map = CageFit(C, kind), CageMap(C, V, kind)
        for p in (4, 5, 6):
            cm = CageMap(C, pins[:p], kind)
            fitted = fit_cage(C, kind, pins[:p], pins[:p] @ sim.T + [10.0, 20.0], cage_map=cm, fit=fit)
            assert np.abs(fitted - (C @ sim.T + [10.0, 20.0])).max() <= 0.5  # a similarity of the pins: the cage's
            for pose in poses.values():
                target = pose(pins[:p])
                fitted = fit_cage(C, kind, pins[:p], target, cage_map=cm, fit=fit)
                assert np.abs(cm.apply(fitted) - target).max() <= 0.5
                U = mesh_map.apply(fitted)
                assert (signed_areas(U, F) * signed_areas(V, F) > 0).all()  # nothing folds
    # an affine motion of the pins gives that affine motion of the cage (affine-precise kinds)
    affine = np.array([[0.75, 0.1], [0.05, 1.1]])
    for kind in ("mvc", "harmonic"):
        fitted = fit_cage(C, kind, pins[:4], pins[:4] @ affine.T + [3.0, 4.0])
        assert np.abs(fitted - (C @ affine.T + [3.0, 4.0])).max() <= 0.1
    # soft pins give way as smooth grows; fixed cage vertices are held
    kind, cm = "mvc", CageMap(C, pins, "mvc")
    target = pins + rng.normal(0.0, 5.0, pins.shape)
    errs = [np.abs(cm.apply(fit_cage(C, kind, pins, target, smooth=s, cage_map=cm)) - target).max()
            for s in (1e-4, 1.0)]
    assert errs[0] < 0.5 < errs[1]
    held = fit_cage(C, kind, pins[:4], target[:4], fixed=([0, 5], [[410.0, 300.0], [330.0, 440.0]]))
    np.testing.assert_allclose(held[[0, 5]], [[410.0, 300.0], [330.0, 440.0]], atol=1e-6)
    np.testing.assert_allclose(CageMap(C, pins[:4], kind).apply(held), target[:4], atol=1e-6)


def test_check_cage_messages():
    assert check_cage(SQUARE) is None
    assert "at least 3" in check_cage([[0, 0], [1, 0]])
    assert "not finite" in check_cage([[0, 0], [1, 0], [np.nan, 1]])
    assert "out of range" in check_cage([[0, 0], [1, 0], [0, 2e6]])
    assert "crosses itself" in check_cage([[0, 0], [1, 1], [1, 0], [0, 1]])
    assert "crosses itself" in check_cage([[0, 0], [2, 0], [2, 2], [1, 0.0]])  # a vertex on an edge
    assert "crosses itself" in check_cage([[0, 0], [2, 0], [1, 0], [1, 1]])  # an edge folding back
    assert "coincide" in check_cage([[0, 0], [1, 0], [1, 0], [0, 1]])
    assert "no area" in check_cage([[0, 0], [1, 0], [2, 0]]) or "crosses" in check_cage([[0, 0], [1, 0], [2, 0]])
    assert "list of [x, y]" in check_cage([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert "list of [x, y]" in check_cage("abc")
    # enclosure of a layer's mesh vertices: points on the cage count as inside
    assert check_encloses(SQUARE, [[0.5, 0.5], [0.5, 0.0], [1.0, 0.3], [0.0, 0.0], [0.3, 1.0]]) is None
    assert check_encloses(SQUARE[::-1], [[0.5, 0.5], [0.0, 0.7]]) is None
    assert check_encloses(SQUARE, [[0.5, 0.5], [1.5, 0.5], [2.0, 2.0]]) == \
        "leaves 2 of the layer's 3 mesh vertices outside (the first at [1.5, 0.5])"


def test_auto_cage_encloses_the_mask():
    H, W = 120, 160
    yy, xx = np.mgrid[0:H, 0:W]
    mask = (((xx - 60) / 40.0) ** 2 + ((yy - 60) / 30.0) ** 2 <= 1.0) | ((xx > 90) & (xx < 140) & (abs(yy - 60) < 8))
    for n, offset in ((12, 6.0), (24, 10.0)):
        C = auto_cage(mask, n, offset)
        assert check_cage(C) is None
        assert 3 <= len(C) <= n
        P = np.c_[xx[mask], yy[mask]].astype(float)
        assert (np.abs(winding(C, P)) > 0.5).all()
        # every mask pixel at least about offset - 1 px from the cage
        P0, P1 = C, np.roll(C, -1, axis=0)
        d, e = P[:, None] - P0[None], (P1 - P0)[None]
        t = np.clip((d * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
        assert np.hypot(*(d - t[..., None] * e).transpose(2, 0, 1)).min() >= offset - 1.5
    two = np.zeros((60, 100), bool)
    two[20:40, 10:30] = two[20:40, 70:90] = True  # two pieces: their hull
    C = auto_cage(two, 8, 4.0)
    assert (np.abs(winding(C, [[20.0, 30.0], [80.0, 30.0], [50.0, 30.0]])) > 0.5).all()
    with pytest.raises(ValueError, match="empty"):
        auto_cage(np.zeros((5, 5), bool), 8, 2.0)


@pytest.mark.parametrize("picture, pins", [  # the "no folds" target on the bundled garments
    ("emoji_u1f457.png", [[182, 30], [315, 30], [198, 189], [302, 189], [100, 428], [425, 416]]),  # dress
    ("emoji_u1f455.png", [[56, 168], [456, 168], [150, 100], [362, 100], [150, 430], [362, 430]]),  # t-shirt
])
def test_bundled_garments_fitted_narrower_through_a_cage(picture, pins):
    alpha = np.asarray(Image.open(ASSETS / "noto-emoji" / picture).convert("RGBA"))[..., 3]
    mask = alpha > 0
    mesh = triangulate_regions(mask_regions(mask), max_area=400.0)  # coarse, to stay cheap
    C = auto_cage(mask, 20, 10.0)
    assert check_cage(C) is None and check_encloses(C, mesh.V) is None
    pins = np.array(pins, float)
    cx = pins[:, 0].mean()
    target = np.c_[cx + 0.75 * (pins[:, 0] - cx), pins[:, 1]]
    for kind in KINDS:
        fitted = fit_cage(C, kind, pins, target)
        assert np.abs(CageMap(C, pins, kind).apply(fitted) - target).max() <= 0.5
        U = CageMap(C, mesh.V, kind).apply(fitted)
        assert (signed_areas(U, mesh.F) * signed_areas(mesh.V, mesh.F) > 0).all(), kind
