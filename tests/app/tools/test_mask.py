"""The task script's rasterising helpers on hand-checked cases (no window)."""
from __future__ import annotations

import numpy as np

from puppet.app.tools import mask as mt
from puppet.imaging.masks import canvas_to_image, image_to_canvas


def test_rect_mask_is_the_pixels_between_the_corners_in_any_order():
    m = mt.rect_mask((10, 12), (8.2, 6.7), (2.0, 3.0))
    assert m.sum() == (9 - 2) * (7 - 3)  # columns 2..8, rows 3..6 (corners widened to whole pixels)
    assert m[3, 2] and m[6, 8] and not m[2, 2] and not m[7, 8] and not m[3, 9]
    assert not mt.rect_mask((10, 12), (-5, -5), (-1, -1)).any()  # off the canvas


def test_polygon_mask_fills_a_square_and_needs_three_points():
    m = mt.polygon_mask((20, 20), [(5, 5), (14, 5), (14, 14), (5, 14)])
    assert m.sum() == 100 and m[5:15, 5:15].all()
    assert not mt.polygon_mask((20, 20), [(1, 1), (10, 10)]).any()


def test_stroke_mask_is_a_round_brush_along_the_path():
    dot = mt.stroke_mask((41, 41), [(20, 20)], 5)
    ys, xs = np.nonzero(dot)
    assert dot[20, 20] and dot[20, 25] and dot[15, 20] and not dot[20, 26] and not dot[26, 20]
    assert np.hypot(xs - 20, ys - 20).max() <= 5.0 + 1e-9
    line = mt.stroke_mask((41, 41), [(5, 20), (35, 20)], 3)
    assert line[20, 5:36].all() and line[17:24, 10:31].all() and not line[:16].any() and not line[25:].any()


def test_canvas_and_image_grids_round_trip_with_an_offset():
    img = np.zeros((4, 5), bool)
    img[1, 2] = img[3, 4] = True
    canvas = image_to_canvas(img, (3, 2), (10, 8))
    assert canvas.shape == (8, 10) and canvas.sum() == 2 and canvas[3, 5] and canvas[5, 7]
    np.testing.assert_array_equal(canvas_to_image(canvas, (3, 2), img.shape), img)
    # partly off the canvas: what is outside is dropped
    assert image_to_canvas(img, (-3, 0), (10, 8)).sum() == 1
