import numpy as np
import pytest

from puppet.scene.format.model import Animation, Key
from puppet.scene.time.timeline import ease, frame_times, segment_at


def test_ease_shapes():
    assert ease("linear", 0.25) == 0.25
    assert ease("smooth", 0.5) == 0.5 and ease("smooth", 0.25) == pytest.approx(0.15625)
    assert ease("step", 0.99) == 0.0 and ease("step", 1.0) == 1.0
    assert ease("linear", -1) == 0.0 and ease("smooth", 2) == 1.0


def test_segments_and_frames():
    an = Animation(fps=4, keys=[Key(0, "rest"), Key(1, "a", "linear"), Key(3, "b", "smooth")])
    assert segment_at(an, -1) == ("rest", "rest", 0.0)
    assert segment_at(an, 0.5) == ("rest", "a", 0.5)
    a, b, t = segment_at(an, 2.0)
    assert (a, b) == ("a", "b") and t == pytest.approx(0.5)
    assert segment_at(an, 9) == ("b", "b", 0.0)
    ft = frame_times(an)
    assert len(ft) == 13 and ft[0] == 0 and ft[-1] == pytest.approx(3.0)
    assert np.allclose(frame_times(an, fps=2, start=1, end=2), [1, 1.5, 2])
