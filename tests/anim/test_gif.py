"""The streaming GIF writer: frames decode back exactly, duplicates merge, the length is
exact, and frames are written as they come (only one is held back)."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from puppet.anim.gif import MIN_DELAY, GifStream, palette_from_sample, quantize


def _decode(data: bytes):
    """Every stored frame of a GIF as (h, w, 3) uint8 RGB (composited), with durations in ms."""
    out = []
    with Image.open(io.BytesIO(data)) as im:
        for k in range(im.n_frames):
            im.seek(k)
            out.append((np.array(im.convert("RGB")), im.info["duration"]))
    return out


def _frames(n, h=24, w=32, seed=0):
    """Frames of a few flat colours with a moving square: exact in a 256-colour palette."""
    rng = np.random.default_rng(seed)
    colours = rng.integers(0, 256, (6, 3), dtype=np.uint8)
    out = []
    for i in range(n):
        f = np.empty((h, w, 3), np.uint8)
        f[:] = colours[0]
        f[:, w // 2:] = colours[1]
        y, x = (2 * i) % (h - 6), (3 * i) % (w - 6)
        f[y:y + 6, x:x + 6] = colours[2 + i % 4]
        out.append(f)
    return out


def _write(frames, fps):
    pal = palette_from_sample(np.concatenate(frames, axis=0))
    buf = io.BytesIO()
    g = GifStream(buf, (frames[0].shape[1], frames[0].shape[0]), pal, fps)
    for f in frames:
        g.add(quantize(f, pal))
    g.close()
    return buf.getvalue(), g


def test_frames_decode_back_exactly():
    frames = _frames(7)
    data, g = _write(frames, fps=10)
    got = _decode(data)
    assert g.frames_written == len(got) == 7
    for want, (have, ms) in zip(frames, got):
        assert np.array_equal(have, want)  # differences-only rectangles composite to the full frame
        assert ms == 100


def test_equal_frames_lengthen_the_previous_one():
    a, b = _frames(2)
    data, g = _write([a, a, a, b, b], fps=10)
    got = _decode(data)
    assert g.frames_added == 5 and g.frames_written == 2
    assert [ms for _, ms in got] == [300, 200]
    assert np.array_equal(got[0][0], a) and np.array_equal(got[1][0], b)


@pytest.mark.parametrize("fps,n", [(30, 30), (24, 49), (7, 10), (12.5, 25)])
def test_total_length_is_exact(fps, n):
    data, _ = _write(_frames(n), fps=fps)
    total_ms = sum(ms for _, ms in _decode(data))
    assert total_ms == 10 * round(100 * n / fps)


def test_fast_frames_get_the_shortest_delay_browsers_honour():
    data, _ = _write(_frames(10), fps=100)
    assert {ms for _, ms in _decode(data)} == {10 * MIN_DELAY}


def test_frames_are_written_as_they_come():
    """After each new frame, the one before it is in the file: one frame held, not all."""
    frames = _frames(6)
    pal = palette_from_sample(np.concatenate(frames, axis=0))
    buf = io.BytesIO()
    g = GifStream(buf, (32, 24), pal, 10)
    sizes = []
    for f in frames:
        g.add(quantize(f, pal))
        sizes.append(len(buf.getvalue()))
    assert sizes[0] == 6 + 7 + 768 + 19  # header, screen, palette, loop: the first frame is held
    assert all(b > a for a, b in zip(sizes, sizes[1:]))
    assert g.frames_written == 5


def test_wrong_frame_size_is_refused():
    pal = palette_from_sample(np.zeros((4, 4, 3), np.uint8))
    g = GifStream(io.BytesIO(), (8, 8), pal, 10)
    with pytest.raises(ValueError, match="frame is 4x8"):
        g.add(np.zeros((8, 4), np.uint8))


@pytest.mark.parametrize("fps", [24, 25, 30, 12, 23.976])
def test_delays_track_the_running_sum(fps):
    """Delays are whole 1/100 s whose running sum is round(100 n / fps): 24 fps gives
    4, 4, 4, 5, 4, 4, ... and any second of frames averages 1/fps within 1 ms."""
    n = 3 * int(fps) + 1
    data, _ = _write(_frames(n, h=30, w=40), fps=fps)
    ms = [ms for _, ms in _decode(data)]
    assert len(ms) == n
    end = np.cumsum(ms) / 10
    assert np.array_equal(end, np.round(100 * np.arange(1, n + 1) / fps))
    k = int(round(fps))
    for s in range(n - k + 1):
        assert abs(sum(ms[s:s + k]) / k - 1000 / fps) <= 1.0 + 1000 * abs(k - fps) / fps / k
    if fps == 24:
        assert ms[:6] == [40, 40, 40, 50, 40, 40]  # ends 4, 8, 12 (12.5 to even), 17, 21, 25


def test_transparent_frames_clear_what_moved_away():
    """With a transparent index, each frame is disposed before the next: a pixel that was
    drawn and is see-through in the next frame reads back clear."""
    frames = _frames(4)
    pal = palette_from_sample(np.concatenate(frames, axis=0), colors=255)
    buf = io.BytesIO()
    g = GifStream(buf, (32, 24), pal, 10, transparent=255)
    masks = []
    for i, f in enumerate(frames):
        idx = quantize(f, pal).copy()
        m = np.zeros((24, 32), bool)
        m[3 * i:3 * i + 8, 4 * i:4 * i + 10] = True  # a box that moves; the rest is see-through
        idx[~m] = 255
        masks.append(m)
        g.add(idx)
    g.close()
    with Image.open(io.BytesIO(buf.getvalue())) as im:
        for k, (m, f) in enumerate(zip(masks, frames)):
            im.seek(k)
            a = np.array(im.convert("RGBA"))
            assert np.array_equal(a[..., 3] == 255, m) and not (a[..., 3] % 255).any()
            assert np.array_equal(a[..., :3][m], f[m])
