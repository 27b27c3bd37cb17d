"""Sprite sheet pieces without GL: the grid, the streamed PNG writer, the atlas."""
from __future__ import annotations

import io
import os

import numpy as np
import pytest
from PIL import Image

from puppet.anim.sheet import MAX_SIDE, Layout, SheetWriter, atlas, layout, write_png


@pytest.mark.parametrize("n,w,h", [(1, 10, 10), (11, 120, 40), (100, 64, 64), (25, 320, 240), (7, 3, 200)])
def test_layout_holds_every_frame_once_near_square(n, w, h):
    lay = layout(n, w, h)
    places = {lay.place(i) for i in range(n)}
    assert len(places) == n
    W, H = lay.size
    assert all(0 <= x <= W - w and 0 <= y <= H - h and x % w == 0 and y % h == 0 for x, y in places)
    assert lay.rows == -(-n // lay.cols)  # no empty row
    if n >= 4:
        assert max(W, H) / min(W, H) <= max(2.0, 2 * max(w, h) / min(w, h))


def test_layout_refuses_what_does_not_fit():
    assert layout(4, MAX_SIDE // 2, MAX_SIDE // 2) == Layout(4, MAX_SIDE // 2, MAX_SIDE // 2, 2, 2)
    assert layout(5, MAX_SIDE // 2, MAX_SIDE // 2) is None
    assert layout(1, MAX_SIDE + 1, 1) is None
    lay = layout(1000, 10, 10, max_side=100)  # 10x10 frames in 100x100: at most 100 of them
    assert lay is None
    assert layout(100, 10, 10, max_side=100).size == (100, 100)


def test_long_strip_uses_the_width():
    lay = layout(50, 16, 1000, max_side=8192)  # tall frames: a wide sheet
    assert lay.size[1] <= 8192 and lay.size[0] <= 8192


@pytest.mark.parametrize("shape", [(1, 1), (7, 5), (40, 120), (33, 17)])
def test_write_png_round_trips_exactly(shape):
    rng = np.random.default_rng(1)
    rgba = rng.integers(0, 256, (*shape, 4), dtype=np.uint8)
    buf = io.BytesIO()
    write_png(buf, rgba)
    with Image.open(io.BytesIO(buf.getvalue())) as im:
        assert im.mode == "RGBA" and np.array_equal(np.array(im), rgba)


def test_sheet_writer_streams_rows_and_reads_back():
    rng = np.random.default_rng(2)
    frames = [rng.integers(0, 256, (96, 90, 4), dtype=np.uint8) for _ in range(7)]  # noise: zlib can't hold it
    lay = Layout(7, 90, 96, 3, 3)
    buf = io.BytesIO()
    sw = SheetWriter(buf, lay, level=1)
    sizes = []
    for f in frames:
        sw.add(f)
        sizes.append(len(buf.getvalue()))
    assert sizes[2] > sizes[1] == sizes[0] and sizes[5] > sizes[4] == sizes[3]  # a row at a time
    sw.close()
    sheet = np.array(Image.open(io.BytesIO(buf.getvalue())))
    assert sheet.shape == (288, 270, 4)
    for i, f in enumerate(frames):
        x, y = lay.place(i)
        assert np.array_equal(sheet[y:y + 96, x:x + 90], f)
    assert not sheet[192:, 90:].any()  # the two empty places of the last row are clear
    with pytest.raises(ValueError, match="holds 7 frames"):
        sw.add(frames[0])


def test_sheet_writer_refuses_short_or_wrong_frames():
    sw = SheetWriter(io.BytesIO(), Layout(2, 4, 4, 2, 1))
    with pytest.raises(ValueError, match="frames are"):
        sw.add(np.zeros((4, 5, 4), np.uint8))
    sw.add(np.zeros((4, 4, 4), np.uint8))
    with pytest.raises(ValueError, match="1 frames given"):
        sw.close()


def test_atlas_is_texturepacker_hash():
    a = atlas(Layout(3, 20, 10, 2, 2), "s.png", 24.0)
    assert list(a["frames"]) == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    assert a["frames"]["frame_00002.png"]["frame"] == {"x": 0, "y": 10, "w": 20, "h": 10}
    assert a["frames"]["frame_00001.png"]["duration"] == pytest.approx(41.667)
    assert a["meta"]["size"] == {"w": 40, "h": 20} and a["meta"]["image"] == "s.png"
