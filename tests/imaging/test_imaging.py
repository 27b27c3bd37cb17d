"""Image loading limits, masks and inpainting."""
import os

import numpy as np
import pytest
from PIL import Image

from puppet.errors import ImageError
from puppet.imaging import masks as mk
from puppet.imaging.inpaint import inpaint, pyramid_fill
from puppet.imaging.io import load_mask_image, load_rgba, save_png


def test_load_rgba_converts_palette_and_grey(tmp_path):
    Image.fromarray(np.full((4, 5), 7, np.uint8)).save(tmp_path / "g.png")
    a = load_rgba(str(tmp_path / "g.png"))
    assert a.shape == (4, 5, 4) and a.dtype == np.uint8 and (a[..., 3] == 255).all() and (a[..., 0] == 7).all()


def test_load_errors_name_the_file(tmp_path):
    with pytest.raises(ImageError, match="no such file"):
        load_rgba(str(tmp_path / "x.png"), scene_file="s.json", json_path="layers[0].image")
    try:
        load_rgba(str(tmp_path / "x.png"), scene_file="s.json", json_path="layers[0].image")
    except ImageError as e:
        assert str(e).startswith("s.json: layers[0].image: image ")


def test_mask_file_alpha_or_grey(tmp_path):
    a = np.zeros((3, 3, 4), np.uint8)
    a[1, 1, 3] = 10
    Image.fromarray(a).save(tmp_path / "a.png")
    g = np.zeros((3, 3), np.uint8)
    g[0, 2] = 1
    Image.fromarray(g).save(tmp_path / "g.png")
    assert load_mask_image(str(tmp_path / "a.png")).sum() == 1 and load_mask_image(str(tmp_path / "a.png"))[1, 1]
    assert load_mask_image(str(tmp_path / "g.png"))[0, 2] and load_mask_image(str(tmp_path / "g.png")).sum() == 1


def test_threshold_polygon_rect_masks():
    img = np.full((10, 10, 4), 255, np.uint8)
    img[2:5, 3:7, :3] = 20
    m = mk.threshold_mask(img, 128)
    assert m.sum() == 12 and m[2:5, 3:7].all()
    assert mk.threshold_mask(img, 128, invert=True).sum() == 88
    r = mk.rect_mask((10, 10), [3, 2, 4, 3], offset=(0, 0))
    assert (r == m).all()
    r2 = mk.rect_mask((10, 10), [13, 12, 4, 3], offset=(10, 10))
    assert (r2 == m).all()
    p = mk.polygon_mask((10, 10), [[3, 2], [7, 2], [7, 5], [3, 5]])
    assert (p == m).all()
    tri = mk.polygon_mask((10, 10), [[0, 0], [10, 0], [0, 10]])
    yy, xx = np.mgrid[:10, :10] + 0.5
    assert (tri == (xx + yy < 10)).sum() >= 95  # centres on the diagonal may go either way


def test_save_png_is_atomic_and_round_trips(tmp_path):
    a = np.random.default_rng(1).integers(0, 256, (7, 9, 4), dtype=np.uint8)
    save_png(str(tmp_path / "o.png"), a)
    assert (load_rgba(str(tmp_path / "o.png")) == a).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.png"]
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "o.png").stat().st_mode & 0o777 == 0o666 & ~umask


@pytest.mark.parametrize("method", ["pyramid", "telea", "ns", "fsr"])
def test_inpaint_takes_colours_of_the_surroundings(method):
    """A hole in a two-colour picture is filled with the colour around it, per side."""
    img = np.zeros((64, 64, 3), np.uint8)
    img[:, :32] = (200, 30, 30)
    img[:, 32:] = (30, 30, 200)
    painted = img.copy()
    painted[20:40, 8:24] = (0, 255, 0)  # a "part" drawn over the red side
    hole = np.zeros((64, 64), bool)
    hole[20:40, 8:24] = True
    out = inpaint(painted, hole, method)
    assert (out[~hole] == painted[~hole]).all()
    fill = out[hole].astype(int)
    assert np.abs(fill - [200, 30, 30]).max() <= 25, fill.max(0)


def test_pyramid_fill_constant_is_exact():
    img = np.full((33, 17, 3), 90, np.uint8)
    hole = np.zeros((33, 17), bool)
    hole[5:30, 2:15] = True
    img[hole] = 0
    assert (pyramid_fill(img, hole) == 90).all()


@pytest.mark.parametrize("method", ["pyramid", "telea", "ns", "fsr"])
def test_layer_fill_ignores_pixels_outside_the_layer(method):
    """A hole touching the layer's outline: transparent black around the layer (and a
    white part elsewhere in the picture) must not bleed into the fill."""
    from puppet.imaging.inpaint import inpaint_layer
    rgba = np.zeros((60, 60, 4), np.uint8)            # transparent black outside
    mask = np.zeros((60, 60), bool)
    mask[10:50, 10:50] = True
    rgba[mask] = (60, 200, 90, 255)
    rgba[20:30, 5:25] = (255, 255, 255, 255)          # a white front part over the edge
    hole = mask & (np.arange(60)[None, :] < 25) & (np.arange(60)[:, None] >= 20) & (np.arange(60)[:, None] < 30)
    out = inpaint_layer(rgba, mask, hole, method)
    fill = out[hole, :3].astype(int)
    assert np.abs(fill - [60, 200, 90]).max() <= 12, fill.min(0)
    assert (out[~hole] == rgba[~hole]).all()
