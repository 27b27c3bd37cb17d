"""Triangle never sees crossing segments or repeated vertices, and never runs on a mesh
larger than the limit (issue 8, part 5)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from puppet.geom import triangulate as tr
from puppet.geom.contour import Region, mask_regions
from puppet.geom.pslg import clean_pslg, segment_conflicts


def _orient(p, q, r) -> int:
    v = (Fraction(q[0]) - Fraction(p[0])) * (Fraction(r[1]) - Fraction(p[1])) \
        - (Fraction(q[1]) - Fraction(p[1])) * (Fraction(r[0]) - Fraction(p[0]))
    return (v > 0) - (v < 0)


def _on(p, q, r) -> bool:
    return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[1], q[1])


def _conflict_exact(P, s, t) -> bool:
    """Exact rational reference: do segments s and t meet anywhere but a shared end?"""
    shared = set(s) & set(t)
    if len(shared) == 2:
        return False
    if shared:
        hub = shared.pop()
        u = P[s[0] if s[1] == hub else s[1]] - P[hub]
        v = P[t[0] if t[1] == hub else t[1]] - P[hub]
        return u[0] * v[1] - u[1] * v[0] == 0 and float(np.dot(u, v)) > 0
    a, b, c, d = P[s[0]], P[s[1]], P[t[0]], P[t[1]]
    o1, o2, o3, o4 = _orient(a, b, c), _orient(a, b, d), _orient(c, d, a), _orient(c, d, b)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return any(o == 0 and _on(x, y, z) for o, x, y, z in
               ((o1, a, b, c), (o2, a, b, d), (o3, c, d, a), (o4, c, d, b)))


def test_conflicts_hand_checked():
    P = np.array([[0, 0], [4, 0], [2, -2], [2, 2], [6, 0], [2, 0], [8, 0]], float)
    S = np.array([[0, 1],    # horizontal 0..4
                  [2, 3],    # vertical at x=2: crosses it
                  [1, 4],    # continues it from its end: fine
                  [4, 6]])   # continues that one: fine
    assert segment_conflicts(P, S).tolist() == [True, True, False, False]
    S = np.array([[0, 1], [0, 5]])  # overlapping from a shared end
    assert segment_conflicts(P, S).tolist() == [True, True]
    S = np.array([[0, 1], [5, 3]])  # an end on the other's interior (a T)
    assert segment_conflicts(P, S).tolist() == [True, True]


def test_conflicts_match_exact_reference_on_grid_degeneracies():
    rng = np.random.default_rng(3)
    for _ in range(70):
        P = np.unique(rng.integers(0, 7, (int(rng.integers(3, 30)), 2)).astype(float), axis=0)
        if len(P) < 3:
            continue
        S = rng.integers(0, len(P), (int(rng.integers(1, 25)), 2))
        S = np.unique(np.sort(S[S[:, 0] != S[:, 1]], axis=1), axis=0)
        want = np.zeros(len(S), bool)
        for i in range(len(S)):
            for j in range(i + 1, len(S)):
                if _conflict_exact(P, S[i], S[j]):
                    want[i] = want[j] = True
        assert segment_conflicts(P, S).tolist() == want.tolist(), (P, S)


def test_clean_pslg_merges_and_dedupes():
    P = np.array([[0, 0], [1, 0], [1, 0], [0, 1]], float)
    g = clean_pslg(P, np.array([[0, 1], [2, 3], [3, 0], [1, 2], [0, 1]]))
    assert len(g["vertices"]) == 3 and sorted(map(tuple, g["segments"].tolist())) == [(0, 1), (0, 2), (1, 2)]


@pytest.mark.parametrize("seed", [0, 190, 203, 282])
def test_noisy_masks_mesh_without_crashing(seed):
    """These masks crashed Triangle (segfault or 'topological inconsistency'): pinched
    holes repeated a vertex, and simplified rings crossed each other."""
    import cv2

    rng = np.random.default_rng(seed)
    if seed == 0:
        m = cv2.GaussianBlur(rng.random((600, 600)), (0, 0), 3) > 0.5
        cases = [(10.0, 25.0, 1.0)]
    else:  # the fuzzer's recipe
        n = int(rng.integers(20, 200))
        sig = float(rng.uniform(0.3, 4))
        m = cv2.GaussianBlur(rng.random((n, n)), (0, 0), sig) > rng.uniform(0.3, 0.7)
        off = tuple(rng.uniform(-1000, 1000, 2)) if rng.random() < 0.5 else (0.0, 0.0)
        simp = float(rng.choice([0, 0.5, 1, 3, 10]))
        a = float(rng.choice([0.5, 1, 3, 20, 400]))
        ang = float(rng.choice([0, 20, 25, 34]))
        cases = [(a, ang, simp)]
        m = (m, off)
    mask, off = m if isinstance(m, tuple) else (m, (0.0, 0.0))
    regions = mask_regions(mask, off)
    if seed == 0:  # the case exercised: a hole ring that touches itself (repeats a vertex)
        from puppet.geom.contour import resample_ring

        h = tr.edge_length_for_area(cases[0][0])
        rings = [resample_ring(tr._simplified(x, 1.0), h) for r in regions for x in r.holes]
        assert any(len(np.unique(np.round(R, 9), axis=0)) < len(R) for R in rings)
    for a, ang, simp in cases:
        M = tr.triangulate_regions(regions, max_area=a, min_angle=ang, simplify=simp)
        assert len(M.F) > 0
        assert (tr.signed_areas(M.V, M.F) < 0).all()  # all counter-clockwise on screen
        # the mesh covers the mask and not much more than the mask grown by one pixel
        total = -0.5 * tr.signed_areas(M.V, M.F).sum()
        grown = cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).sum()
        assert mask.sum() < total < 1.2 * grown


def _square(n: int) -> list[Region]:
    m = np.zeros((n + 4, n + 4), bool)  # noqa
    m[2:-2, 2:-2] = True
    return mask_regions(m)


@pytest.mark.parametrize("max_area,min_angle", [(2.0, 25.0), (10.0, 25.0), (50.0, 34.0), (400.0, 20.0)])
def test_estimate_is_close_on_compact_shapes(max_area, min_angle, monkeypatch):
    seen = {}
    real = tr.estimate_triangles

    def spy(*a, **k):
        seen["n"] = real(*a, **k)
        return seen["n"]

    monkeypatch.setattr(tr, "estimate_triangles", spy)
    M = tr.triangulate_regions(_square(400), max_area=max_area, min_angle=min_angle)
    assert 0.9 * len(M.F) <= seen["n"] <= 1.3 * len(M.F), (seen["n"], len(M.F))


def test_too_many_triangles_refused_before_triangle_runs(monkeypatch):
    import triangle

    def boom(*a, **k):
        raise AssertionError("Triangle must not run")

    monkeypatch.setattr(triangle, "triangulate", boom)
    with pytest.raises(tr.MeshTooLarge) as e:
        tr.triangulate_regions(_square(400), max_area=1.0, max_triangles=100_000)
    # 1.6 x 160000 px² / 1 px² = 256000 (+ boundary) triangles; a max_area of 2.56+ would fit
    assert 256_000 < e.value.estimate < 262_000
    assert 2.5 < e.value.smallest < 2.7 and f"max_area >= {e.value.smallest:.3g}" in str(e.value)
    monkeypatch.undo()
    M = tr.triangulate_regions(_square(400), max_area=e.value.smallest * 1.05, max_triangles=100_000)
    assert len(M.F) <= 100_000


def test_simplified_rings_that_cross_fall_back_to_the_raw_outline():
    """Ring A has a 2 px bay (below the 3 px tolerance: simplified away), ring B a 3.5 px
    bump (kept) reaching into it: simplified, A's straightened edge cuts B's bump."""
    A = np.array([[0, 0], [100, 0], [100, 20], [60, 20], [60, 18], [40, 18], [40, 20], [0, 20]], float)
    B = np.array([[0, 22], [45, 22], [45, 18.5], [55, 18.5], [55, 22], [100, 22], [100, 40], [0, 40]], float)
    simple = [tr._simplified(R, 3.0) for R in (A, B)]
    assert len(simple[0]) == 4 and simple[1][:, 1].min() == 18.5  # bay gone, bump kept
    P = np.concatenate(simple)
    n = len(simple[1])
    S = np.array([[i, (i + 1) % 4] for i in range(4)] + [[4 + i, 4 + (i + 1) % n] for i in range(n)])
    assert segment_conflicts(P, S).any()
    M = tr.triangulate_regions([Region(A), Region(B)], max_area=5.0, simplify=3.0)
    area = -0.5 * tr.signed_areas(M.V, M.F).sum()
    assert area == pytest.approx(abs(tr._signed(A)) + abs(tr._signed(B)), abs=1e-6)
