"""Polygon masks: even-odd fill (self-intersecting polygons follow the rule instead of
being refused), bounded work."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.imaging import masks as mk


def _inside_even_odd(P, x, y) -> bool:
    """Reference: crossings of a ray to the right, counted one edge at a time."""
    inside = False
    for (ax, ay), (bx, by) in zip(P, np.roll(P, -1, axis=0)):
        if (ay <= y) != (by <= y):
            if x < ax + (y - ay) * (bx - ax) / (by - ay):
                inside = not inside
    return inside


def test_bowtie_fills_both_lobes():
    P = np.array([[0, 0], [20, 10], [20, 0], [0, 10]], float)  # crosses itself at (10, 5)
    m = mk.polygon_mask((10, 20), P)
    assert m[5, 1] and m[5, 18]                # both lobes
    assert not m[1, 10] and not m[8, 10]       # above and below the crossing
    assert m.sum() == sum(_inside_even_odd(P, j + 0.5, i + 0.5) for i in range(10) for j in range(20))
    # the old shoelace test called this "no area": the two lobes cancel
    x, y = P[:, 0], P[:, 1]
    assert abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) < 1e-9


def test_pentagram_core_is_outside():
    t = np.pi / 2 + np.arange(5) * 4 * np.pi / 5
    P = np.stack([50 + 40 * np.cos(t), 50 + 40 * np.sin(t)], axis=1)
    m = mk.polygon_mask((100, 100), P)
    assert not m[50, 50]                       # the doubly wound core
    assert m[int(50 + 30 * np.sin(t[0])), int(50 + 30 * np.cos(t[0]))]  # a point of the star
    want = np.array([[_inside_even_odd(P, j + 0.5, i + 0.5) for j in range(100)] for i in range(100)])
    assert (m == want).all()


def test_random_self_intersecting_polygons_match_reference():
    rng = np.random.default_rng(5)
    for _ in range(8):
        P = rng.uniform(-5, 35, (int(rng.integers(3, 12)), 2))
        off = rng.uniform(-3, 3, 2)
        m = mk.polygon_mask((30, 30), P, off)
        want = np.array([[_inside_even_odd(P - off, j + 0.5, i + 0.5) for j in range(30)] for i in range(30)])
        assert (m == want).all()


def test_chunks_give_the_same_mask(monkeypatch):
    rng = np.random.default_rng(1)
    P = rng.uniform(0, 200, (300, 2))
    whole = mk.polygon_mask((200, 200), P)
    monkeypatch.setattr(mk, "CHUNK", 97)
    assert (mk.polygon_mask((200, 200), P) == whole).all()


def test_crossings_count():
    P = np.array([[0, 0], [10, 100], [20, 0]], float)  # two slanted edges spanning 100 rows, one flat
    assert mk.polygon_crossings(P, height=1000) == 200
    assert mk.polygon_crossings(P, height=50) == 100           # clipped to the image
    assert mk.polygon_crossings(P, offset=(0, 60), height=1000) == 80
