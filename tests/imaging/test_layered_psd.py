"""PSD rules of the layered import, each on a small PSD written with psd-tools: groups
and tags, opacity, masks, clipping, blend modes, and bad input (one line, exit 2)."""
import hashlib
import os
import struct

import numpy as np
import pytest
from PIL import Image

from puppet.cli import main
from puppet.errors import ImageError
from puppet.imaging.layered import read_layered


def block(w, h, colour, alpha=255):
    a = np.zeros((h, w, 4), np.uint8)
    a[..., :3], a[..., 3] = colour, alpha
    return Image.fromarray(a)


def new_psd(size=(100, 80)):
    from psd_tools import PSDImage

    return PSDImage.new("RGBA", size, color=(0, 0, 0, 0))


def saved(psd, tmp_path, name="a.psd"):
    path = str(tmp_path / name)
    psd.save(path)
    return path


def by_name(art):
    return {lay.name: lay for lay in art.layers}


def test_groups_tags_and_names(tmp_path):
    psd = new_psd()
    psd.create_pixel_layer(block(10, 10, (255, 0, 0)), name="back", left=0, top=0)
    g = psd.create_group(name="arm [merge]")
    g.create_pixel_layer(block(10, 10, (0, 255, 0)), name="upper", left=20, top=0)
    g.create_pixel_layer(block(10, 10, (0, 0, 255)), name="lower", left=25, top=5)
    h = psd.create_group(name="legs")
    h.create_pixel_layer(block(5, 5, (9, 9, 9)), name="l", left=50, top=50)
    h.create_pixel_layer(block(5, 5, (9, 9, 9)), name="l", left=60, top=50)
    h.create_pixel_layer(block(5, 5, (9, 9, 9)), name="notes [ignore]", left=70, top=50)
    psd.create_group(name="refs [IGNORE]").create_pixel_layer(block(5, 5, (1, 1, 1)), name="x")
    art = read_layered(saved(psd, tmp_path))
    assert [lay.name for lay in art.layers] == ["back", "arm", "legs/l", "legs/l-2"]
    arm = by_name(art)["arm"]
    assert arm.offset == (20, 0) and arm.rgba.shape == (15, 15, 4)
    assert tuple(arm.rgba[7, 7]) == (0, 0, 255, 255) and tuple(arm.rgba[2, 2]) == (0, 255, 0, 255)
    assert arm.rgba[12, 2, 3] == 0  # the merged group keeps its own transparency
    assert art.notes == []


def test_opacity_of_layer_and_group_is_multiplied_into_alpha(tmp_path):
    psd = new_psd()
    psd.create_pixel_layer(block(10, 10, (255, 0, 0)), name="half", opacity=128)
    g = psd.create_group(name="g", opacity=128)
    g.create_pixel_layer(block(10, 10, (255, 0, 0), alpha=200), name="quarter", left=20, opacity=128)
    art = by_name(read_layered(saved(psd, tmp_path)))
    assert abs(int(art["half"].rgba[0, 0, 3]) - 128) <= 1
    assert abs(int(art["g/quarter"].rgba[0, 0, 3]) - round(200 * 128 / 255 * 128 / 255)) <= 1
    assert tuple(art["g/quarter"].rgba[0, 0, :3]) == (255, 0, 0)


def test_layer_mask_and_clipping_are_baked(tmp_path):
    psd = new_psd()
    base = psd.create_pixel_layer(block(40, 40, (255, 0, 0)), name="base", left=10, top=10)
    m = np.full((40, 40), 255, np.uint8)
    m[:, 20:] = 0  # the right half masked out
    base.create_mask(Image.fromarray(m))
    clip = psd.create_pixel_layer(block(60, 10, (0, 0, 255)), name="stripe", left=0, top=20)
    clip.clipping = True
    art = read_layered(saved(psd, tmp_path))
    assert [lay.name for lay in art.layers] == ["base"]  # the clipped layer is inside its base
    lay = art.layers[0]
    assert lay.offset == (10, 10) and lay.rgba.shape[:2] == (40, 20)  # cropped to the unmasked half
    assert tuple(lay.rgba[0, 0]) == (255, 0, 0, 255)
    assert tuple(lay.rgba[15, 5]) == (0, 0, 255, 255)  # the stripe, only where the base is


def test_blend_mode_is_baked_into_the_layer_below(tmp_path):
    from psd_tools.constants import BlendMode

    psd = new_psd()
    psd.create_pixel_layer(block(20, 20, (200, 100, 50)), name="body", left=10, top=10)
    psd.create_pixel_layer(block(30, 5, (128, 128, 128)), name="shade", left=0, top=12,
                           blend_mode=BlendMode.MULTIPLY)
    art = read_layered(saved(psd, tmp_path))
    assert [lay.name for lay in art.layers] == ["body", "shade"]
    body, rest = art.layers
    assert tuple(body.rgba[4, 5]) == (100, 50, 25, 255)  # multiplied by 128/255
    assert tuple(body.rgba[0, 0]) == (200, 100, 50, 255)
    # the shade's part beyond the body stays, drawn normal: x 0..9 and 30..29 (none) of rows 12..16
    assert rest.offset == (0, 12) and rest.rgba.shape[:2] == (5, 10)
    assert tuple(rest.rgba[0, 0]) == (128, 128, 128, 255)
    assert len(art.notes) == 1 and "multiply baked into 'body'" in art.notes[0]


def test_blend_mode_over_nothing_is_normal(tmp_path):
    from psd_tools.constants import BlendMode

    psd = new_psd()
    psd.create_pixel_layer(block(30, 5, (128, 128, 128)), name="glow", blend_mode=BlendMode.SCREEN)
    psd.create_pixel_layer(block(20, 20, (200, 100, 50)), name="body", left=10, top=10)
    art = read_layered(saved(psd, tmp_path))
    assert [lay.name for lay in art.layers] == ["glow", "body"]  # over nothing, screen is normal
    assert tuple(art.layers[0].rgba[0, 0]) == (128, 128, 128, 255)
    assert "glow: blend mode screen over nothing is normal" in art.notes[0]


def test_sixteen_bit_document_imports(tmp_path):
    from psd_tools import PSDImage

    psd = PSDImage.new("RGBA", (40, 30), color=(0, 0, 0, 0), depth=16)
    a = np.zeros((10, 10, 4), np.uint16)
    a[..., 0], a[..., 3] = 65535, 65535
    a[..., 1] = 32768
    psd.create_pixel_layer_from_array(a, name="deep", left=5, top=6)
    art = read_layered(saved(psd, tmp_path))
    lay = art.layers[0]
    assert lay.offset == (5, 6) and tuple(lay.rgba[3, 3]) == (255, 128, 0, 255)


def psd_header(w, h, depth=8, mode=3, version=1):
    return b"8BPS" + struct.pack(">H6xHIIHH", version, 4, h, w, depth, mode)


def folder(p):
    p.mkdir()
    return p


def run(tmp_path, capsys, art):
    out = str(tmp_path / "s.json")
    rc = main(["init", str(art), "-o", out])
    err = capsys.readouterr().err
    return rc, err, out


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data)
    return p


@pytest.mark.parametrize("make, words", [
    (lambda t: write(t, "png.psd", open(os.path.join(os.path.dirname(__file__), "..", "..", "assets", "horse",
                                                     "horse.png"), "rb").read()), "not a Photoshop file"),
    (lambda t: write(t, "empty.psd", b""), "not a Photoshop file"),
    (lambda t: write(t, "cmyk.psd", psd_header(10, 10, mode=4) + b"\0" * 64), "corrupt"),
    (lambda t: write(t, "multi.psd", psd_header(10, 10, mode=7) + b"\0" * 64), "multichannel colour mode"),
    (lambda t: write(t, "hdr.psd", psd_header(10, 10, depth=7) + b"\0" * 64), "bit depth 7"),
    (lambda t: write(t, "duo.psd", psd_header(10, 10, mode=8) + b"\0" * 64), "duotone colour mode"),
    (lambda t: write(t, "huge.psb", psd_header(30000, 30000, version=2) + b"\0" * 64), "too large (30000x30000"),
    (lambda t: write(t, "zero.psd", psd_header(0, 10)), "empty (0x10)"),
    (lambda t: write(t, "v3.psd", psd_header(10, 10, version=3)), "version 3"),
    (lambda t: t / "missing.psd", "no such file"),
    (lambda t: folder(t / "dir.psd"), "not a regular file"),
])
def test_bad_files_are_one_line(tmp_path, capsys, make, words):
    art = make(tmp_path)
    before = art.read_bytes() if art.is_file() else None
    rc, err, out = run(tmp_path, capsys, art)
    assert rc == 2 and err.startswith("puppet: error: ") and err.count("\n") == 1, err
    assert words in err and not os.path.exists(out)
    if before is not None:
        assert art.read_bytes() == before


def test_truncated_psd_is_one_line(tmp_path, capsys):
    psd = new_psd()
    for i in range(3):
        psd.create_pixel_layer(block(40, 40, (10 * i, 0, 0)), name=f"l{i}", left=i * 10)
    data = open(saved(psd, tmp_path), "rb").read()
    for cut in (30, 200, len(data) // 2, len(data) - 50):
        art = write(tmp_path, f"cut{cut}.psd", data[:cut])
        rc, err, out = run(tmp_path, capsys, art)
        assert rc in (0, 2), err
        if rc == 2:
            assert err.startswith("puppet: error: ") and err.count("\n") == 1, err


def test_every_layer_hidden_or_no_pixels_is_one_line(tmp_path, capsys):
    psd = new_psd()
    psd.create_pixel_layer(block(10, 10, (1, 2, 3)), name="a").visible = False
    psd.create_pixel_layer(block(10, 10, (1, 2, 3)), name="b").visible = False
    rc, err, out = run(tmp_path, capsys, saved(psd, tmp_path, "hidden.psd"))
    assert rc == 2 and "every layer is hidden" in err and err.count("\n") == 1
    psd = new_psd()
    psd.create_pixel_layer(block(10, 10, (1, 2, 3), alpha=0), name="clear")
    rc, err, out = run(tmp_path, capsys, saved(psd, tmp_path, "clear.psd"))
    assert rc == 2 and "nothing to import" in err and err.count("\n") == 1


def test_a_layer_larger_than_the_limits_is_refused_before_decoding(tmp_path, monkeypatch):
    import puppet.imaging.io as io

    psd = new_psd((50, 40))  # the layer reaches beyond the canvas
    psd.create_pixel_layer(block(60, 50, (1, 2, 3)), name="big", left=-5, top=-5)
    path = saved(psd, tmp_path)
    monkeypatch.setattr(io, "MAX_SIDE", 55)
    with pytest.raises(ImageError, match=r"layer 'big': too large \(60x50"):
        read_layered(path)


def test_the_art_file_is_never_modified(tmp_path, capsys):
    psd = new_psd()
    psd.create_pixel_layer(block(10, 10, (1, 2, 3)), name="a")
    path = saved(psd, tmp_path)
    digest = hashlib.sha256(open(path, "rb").read()).hexdigest()
    mtime = os.stat(path).st_mtime_ns
    for flags in ([], ["--pins", "auto"], ["--update"]):
        assert main(["init", path, "-o", str(tmp_path / "s.json"), *flags]) in (0, 2)
    assert hashlib.sha256(open(path, "rb").read()).hexdigest() == digest
    assert os.stat(path).st_mtime_ns == mtime


def test_cmyk_document_is_converted_to_rgb(tmp_path):
    from psd_tools import PSDImage

    psd = PSDImage.new("CMYK", (20, 10))
    psd.create_pixel_layer(Image.new("CMYK", (8, 6), (0, 255, 255, 0)), name="red", left=2, top=3)
    psd.create_pixel_layer(Image.new("CMYK", (4, 4), (0, 0, 0, 128)), name="grey", left=12, top=1)
    path = saved(psd, tmp_path, "cmyk.psd")
    art = read_layered(path)
    red, grey = art.layers
    assert red.offset == (2, 3) and tuple(red.rgba[0, 0]) == (255, 0, 0, 255)
    assert abs(int(grey.rgba[0, 0, 0]) - 127) <= 1 and grey.rgba[0, 0, 0] == grey.rgba[0, 0, 2]
    ref = np.asarray(PSDImage.open(path).composite().convert("RGBA"))
    from puppet.imaging.layered import over

    mine = over(art.layers, art.size)
    shown = ref[..., 3] == 255
    assert np.abs(mine[shown, :3].astype(int) - ref[shown, :3]).max() <= 2


def test_a_30000_px_layer_is_refused_by_the_image_limits(tmp_path, capsys):
    psd = new_psd((100, 80))
    layer = psd.create_pixel_layer(block(10, 10, (255, 0, 0)), name="wide")
    layer._record.right = 30000  # the record claims 30000 px; no pixel of it is ever decoded
    path = saved(psd, tmp_path, "wide.psb")
    rc, err, out = run(tmp_path, capsys, path)
    assert rc == 2 and err.count("\n") == 1
    assert "layer 'wide': too large (30000x10; at most 16384 per side" in err and not os.path.exists(out)


def test_over_hand_checked():
    from puppet.imaging.layered import ArtLayer, over

    back = ArtLayer("b", np.array([[[0, 0, 255, 255]]], np.uint8), (0, 0))
    front = ArtLayer("f", np.array([[[255, 0, 0, 128], [255, 0, 0, 128]]], np.uint8), (0, 0))
    out = over([back, front], (3, 1))
    assert tuple(out[0, 0]) == (128, 0, 127, 255)  # 128/255 red over opaque blue
    assert tuple(out[0, 1]) == (255, 0, 0, 128)  # over nothing: unchanged
    assert tuple(out[0, 2]) == (0, 0, 0, 0)


def test_a_file_larger_than_the_bound_is_refused_before_reading(tmp_path, monkeypatch):
    import puppet.imaging.layered.psd as P

    psd = new_psd()
    psd.create_pixel_layer(block(10, 10, (1, 2, 3)), name="a")
    path = saved(psd, tmp_path)
    monkeypatch.setattr(P, "MAX_FILE", 1000)
    with pytest.raises(ImageError, match=r"file too large \(\d+ bytes; at most 0 MiB\)"):
        read_layered(path)
