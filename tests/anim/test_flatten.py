"""sinks.flatten: straight RGBA over an opaque colour, byte for byte the float32 formula
computed on every pixel (the fast path computes only translucent pixels)."""
import numpy as np
import pytest

from puppet.anim import sinks


def every_pixel(rgba, over=(255, 255, 255)):
    """The formula on every pixel, as flatten computed it before issue 31."""
    if rgba.shape[2] == 3 or rgba[..., 3].min() == 255:
        return rgba[..., :3]
    a = rgba[..., 3:4].astype(np.float32) / 255.0
    rgb = rgba[..., :3].astype(np.float32) * a + np.asarray(over, np.float32) * (1.0 - a)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("over", [(255, 255, 255), (0, 0, 0), (12, 200, 99)])
def test_every_colour_and_alpha_pair_matches_the_formula(over):
    c, a = np.meshgrid(np.arange(256), np.arange(256))
    rgba = np.stack([c, (c * 7) % 256, 255 - c, a], -1).astype(np.uint8)
    for view in (rgba, rgba[::3, 1::2], rgba[:, ::-1]):
        got = sinks.flatten(view, over)
        assert got.shape == view.shape[:2] + (3,) and got.dtype == np.uint8
        assert np.array_equal(got, every_pixel(view, over))


def test_a_frame_with_opaque_clear_and_edge_pixels_matches_and_opaque_frames_are_sliced():
    rng = np.random.default_rng(3)
    rgba = rng.integers(0, 256, (37, 53, 4), dtype=np.uint8)
    rgba[:10, :, 3], rgba[10:30, :, 3] = 0, 255
    assert np.array_equal(sinks.flatten(rgba, (30, 60, 90)), every_pixel(rgba, (30, 60, 90)))
    rgba[..., 3] = 255
    assert np.array_equal(sinks.flatten(rgba), rgba[..., :3])
    rgb = rgba[..., :3].copy()
    assert sinks.flatten(rgb) is rgb
