"""Real Photoshop files (psd-tools' corpus, tests/data/psd-tools): each imports as its
visible layers and the imported layers, composited back to front, give the file's
composite (psd-tools' compositor) within 2 grey levels on opaque pixels."""
import os

import numpy as np
import pytest

from puppet.imaging.layered import over, read_layered

DATA = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "psd-tools")

CASES = {
    "2layers.psd": ["Фон", "Слой"],
    "16bit5x5.psd": ["Background", "Background copy", "Background copy 2"],
    "32bit5x5.psb": ["Background", "Background copy", "Background copy 2"],  # PSB, linear light
    "clip-opacity.psd": ["Gradient Fill 2", "Gradient Fill 1"],  # a clipping layer and opacity
    "clipping-mask3.psd": ["Background", "Group 1"],  # a group with a clipping layer over it
    "group.psd": ["Background", "Group 1/Shape 1"],
    "hidden-layer.psd": ["Background", "Shape 1"],
    "masks-2.psd": ["ellipse1", "ellipse2", "ellipse3"],  # layer masks
    "blend-multiply.psd": ["Ellipse 1", "Ellipse 2", "Ellipse 3"],  # multiply, 50 % opacity
    # four levels adjustments (two masked) over a picture and colour swatches
    "adjustments-levels_rgb.psd": ["orion", "color palettes/Layer 1", "color palettes/Layer 8 copy",
                                   "color palettes/Layer 8 copy 2", "color palettes/Layer 8 copy 3"],
    # an exposure adjustment in a pass-through group at 50 % opacity (80 grey levels off before)
    "passthrough_opacity.psd": ["Background", "Layer 1", "Group 1/Layer 1 copy"],
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_real_file_imports_as_its_layers_and_composite(name):
    from psd_tools import PSDImage

    path = os.path.join(DATA, name)
    art = read_layered(path)
    assert [lay.name for lay in art.layers if lay.visible] == CASES[name]
    mine = over([lay for lay in art.layers if lay.visible], art.size).astype(float)
    ref = np.asarray(PSDImage.open(path).composite().convert("RGBA")).astype(float)
    assert np.abs(mine[..., 3] - ref[..., 3]).mean() < 1.0
    opaque = ref[..., 3] == 255
    if opaque.any():
        assert np.abs(mine[opaque, :3] - ref[opaque, :3]).mean() < 2.0
    shown = ref[..., 3] > 0  # premultiplied colours where anything shows
    pm = lambda a: a[shown, :3] * a[shown, 3:] / 255  # noqa: E731
    assert np.abs(pm(mine) - pm(ref)).mean() < 2.0


def test_a_pass_through_groups_adjustment_matches_the_file_at_every_pixel():
    """Issue 32: ``passthrough_opacity.psd`` rendered 84,42,42 against the file's 169,127,127
    at its centre; the group's opacity now shares the adjustment out per pixel."""
    from psd_tools import PSDImage

    path = os.path.join(DATA, "passthrough_opacity.psd")
    art = read_layered(path)
    mine = over(art.layers, art.size).astype(int)
    ref = np.asarray(PSDImage.open(path).composite().convert("RGBA")).astype(int)
    assert np.abs(mine - ref).max() <= 2


def test_a_hidden_layer_is_kept_hidden_with_its_pixels():
    """Issue 32: hidden layers were dropped; they are kept, not visible, unchanged by what
    is baked into the visible layers."""
    from psd_tools import PSDImage

    path = os.path.join(DATA, "hidden-layer.psd")
    art = read_layered(path)
    (hidden,) = [lay for lay in art.layers if not lay.visible]
    assert hidden.name == "Shape 2" and art.hidden == ["Shape 2"]
    layer = next(x for x in PSDImage.open(path).descendants() if x.name == "Shape 2")
    assert hidden.rgba[..., 3].any() and hidden.offset[0] >= layer.bbox[0] and hidden.offset[1] >= layer.bbox[1]


def test_adjustments_are_baked_into_the_layers_below():
    art = read_layered(os.path.join(DATA, "adjustments-levels_rgb.psd"))
    baked = [n for n in art.notes if "adjustment (levels) baked into" in n]
    assert len(baked) == 4, art.notes  # without them the composite differs by ~40 grey levels


def test_lab_file_is_converted_to_srgb():
    art = read_layered(os.path.join(DATA, "stroke-color-descriptors-lab.psd"))
    assert [lay.name for lay in art.layers] == ["Background", "Rectangle 1", "Rectangle 2"]
    assert tuple(art.layers[0].rgba[0, 0]) == (255, 255, 255, 255)  # L 100, a 0, b 0


def test_lab_to_srgb_hand_checked():
    from puppet.imaging.layered.psd import lab_to_linear, srgb_encode

    def rgb(L, a, b):
        lab = np.array([L / 100, (a + 128) / 255, (b + 128) / 255], np.float32)
        return np.round(srgb_encode(lab_to_linear(lab)) * 255)
    assert tuple(rgb(100, 0, 0)) == (255, 255, 255) and tuple(rgb(0, 0, 0)) == (0, 0, 0)
    assert tuple(rgb(50, 0, 0)) == (119, 119, 119)  # mid grey: L* 50 is sRGB 119
    r, g, b = rgb(54.29, 80.81, 69.89)  # sRGB red in Lab (D50)
    assert r >= 250 and g <= 10 and b <= 10
