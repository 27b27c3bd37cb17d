"""Record mode's path simplification (pure numpy, no window)."""
from __future__ import annotations

import numpy as np
import pytest
pytest.importorskip("hypothesis", reason="hypothesis (a test extra: pip install -e '.[test]') is not installed")
from hypothesis import given, settings
from hypothesis import strategies as st

from puppet.app.model.record import Recording, dedupe_times, replay, simplify_path, synchronised_errors


def test_synchronised_error_hand_checked():
    # from (0,0) at t=0 to (10,0) at t=1; the middle sample is at (5,0) but at t=0.25:
    # the segment is at (2.5,0) then, so the error is 2.5 (0 for shape-only Douglas-Peucker)
    t = np.array([0.0, 0.25, 1.0])
    p = np.array([[0, 0], [5, 0], [10, 0]], float)
    np.testing.assert_allclose(synchronised_errors(t, p, 0, 2), [0, 2.5, 0])
    assert simplify_path(t, p, 2.4).tolist() == [0, 1, 2]
    assert simplify_path(t, p, 2.6).tolist() == [0, 2]


def test_straight_uniform_motion_is_two_keys():
    t = np.linspace(0, 2, 50)
    p = np.stack([10 + 30 * t, 5 - 4 * t], 1)
    assert simplify_path(t, p, 0.01).tolist() == [0, 49]


def test_a_pause_on_a_straight_line_is_kept():
    # moves 0->10 in 1 s, waits 1 s, moves 10->20 in 1 s: three segments, four keys
    t = np.linspace(0, 3, 61)
    x = np.clip(t, 0, 1) * 10 + np.clip(t - 2, 0, 1) * 10
    p = np.stack([x, np.zeros_like(x)], 1)
    keep = simplify_path(t, p, 0.5)
    np.testing.assert_allclose(t[keep], [0, 1, 2, 3], atol=1e-9)


def test_corner_kept_and_tolerance_decides():
    t = np.linspace(0, 1, 21)
    p = np.where(t[:, None] <= 0.5, np.stack([t * 40, 0 * t], 1), np.stack([20 + 0 * t, (t - 0.5) * 40], 1))
    keep = simplify_path(t, p, 1.0)
    assert keep.tolist() == [0, 10, 20]
    # a tolerance above the largest deviation keeps only the ends
    assert simplify_path(t, p, 100.0).tolist() == [0, 20]


def test_few_samples_and_errors():
    assert simplify_path([0.0], [[1, 2]], 1).tolist() == [0]
    assert simplify_path([0.0, 1.0], [[1, 2], [3, 4]], 1).tolist() == [0, 1]
    with pytest.raises(ValueError):
        simplify_path([0.0, 1.0, 0.5], [[0, 0], [1, 1], [2, 2]], 1)
    with pytest.raises(ValueError):
        simplify_path([0.0, 1.0], [[0, 0]], 1)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.001, 0.2), st.floats(-50, 50), st.floats(-50, 50)), min_size=1, max_size=60),
       st.floats(0.05, 20))
def test_replay_within_tolerance(steps, tol):
    """The invariant: the kept samples replayed linearly in time are within the tolerance
    of every recorded sample."""
    t = np.cumsum([0.0] + [s[0] for s in steps])
    p = np.cumsum([[0.0, 0.0]] + [[s[1], s[2]] for s in steps], axis=0)
    keep = simplify_path(t, p, tol)
    assert keep[0] == 0 and keep[-1] == len(t) - 1 and np.all(np.diff(keep) > 0)
    err = np.hypot(*(replay(t[keep], p[keep], t) - p).T)
    assert err.max() <= tol + 1e-9


def test_dedupe_times():
    t, p = dedupe_times([0, 0, 0.5, 0.5005, 1.0], [[0, 0], [1, 1], [2, 2], [3, 3], [4, 4]], 0.002)
    assert t.tolist() == [0, 0.5, 1.0]
    assert p.tolist() == [[0, 0], [3, 3], [4, 4]]


def test_recording_speed_and_keys():
    rec = Recording(start=1.0, speed=0.5, now=100.0)
    for k in range(11):  # 2 s of real time, the pin moving right at 10 px a real second
        rec.add(100.0 + 0.2 * k, {"hand": (10 + 2 * k, 20)})
    assert rec.time(102.0) == pytest.approx(2.0)  # half speed: 2 real s -> 1 timeline s
    keys = rec.keys(0.5)
    assert list(keys) == [1.0, 2.0] and keys[1.0] == {"hand": [10, 20]} and keys[2.0] == {"hand": [30, 20]}
