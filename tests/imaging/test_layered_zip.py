"""OpenRaster and Krita files: stack.xml / maindoc.xml, LZF tiles, bounded zip members."""
import io
import zipfile

import numpy as np
import pytest
from PIL import Image

from puppet.errors import ImageError
from puppet.imaging.layered import read_layered
from puppet.imaging.layered.kra import lzf_decompress
from puppet.imaging.layered.zipped import member
from tests import artfiles
from tests.artfiles import NAMES


# -- LZF, hand-checked streams -----------------------------------------------------------
def test_lzf_literals_and_back_references():
    assert lzf_decompress(bytes([2]) + b"abc", 3) == b"abc"
    # "abc" then a reference of length 6 at distance 3 (overlapping its own output)
    assert lzf_decompress(bytes([2]) + b"abc" + bytes([(4 << 5) | 0, 2]), 9) == b"abcabcabc"
    # a long reference: length field 7, extra byte 10 -> 7 + 10 + 2 = 19 bytes at distance 1
    assert lzf_decompress(bytes([0]) + b"z" + bytes([7 << 5, 10, 0]), 20) == b"z" * 20
    # distance with the high bits: 300 literal bytes then copy 3 from distance 300
    lit = bytes(range(256)) + bytes(range(44))
    stream = b"".join(bytes([len(lit[i:i + 32]) - 1]) + lit[i:i + 32] for i in range(0, 300, 32))
    d = 300 - 1
    assert lzf_decompress(stream + bytes([(1 << 5) | (d >> 8), d & 255]), 303) == lit + lit[:3]


@pytest.mark.parametrize("data, size", [
    (bytes([(1 << 5), 5]), 3),          # a reference before anything was written
    (bytes([2]) + b"abc", 4),           # too short
    (bytes([2]) + b"abc" + bytes([1 << 5]), 6),  # truncated reference
])
def test_lzf_rejects_broken_streams(data, size):
    with pytest.raises(ValueError):
        lzf_decompress(data, size)


def lzf_compress(raw: bytes) -> bytes:
    """A small LZF writer for the tests: runs of a repeated byte as distance-1 references,
    everything else as literals (enough to exercise both kinds of token)."""
    out, i, lit = bytearray(), 0, bytearray()

    def flush():
        for k in range(0, len(lit), 32):
            out.append(len(lit[k:k + 32]) - 1)
            out.extend(lit[k:k + 32])
        lit.clear()
    while i < len(raw):
        j = i + 1
        while j < len(raw) and raw[j] == raw[i] and j - i < 264:
            j += 1
        if j - i >= 4:
            lit.append(raw[i])
            flush()
            n = j - i - 1 - 2
            if n >= 7:
                out += bytes([7 << 5, n - 7, 0])
            else:
                out += bytes([n << 5, 0])
            i = j
        else:
            lit.append(raw[i])
            i += 1
    flush()
    return bytes(out)


def tile_file(rgba: np.ndarray, tw=64, th=64) -> bytes:
    h, w = rgba.shape[:2]
    H, W = -(-h // th) * th, -(-w // tw) * tw
    pad = np.zeros((H, W, 4), np.uint8)
    pad[:h, :w] = rgba
    tiles = []
    for y in range(0, H, th):
        for x in range(0, W, tw):
            bgra = pad[y:y + th, x:x + tw][..., [2, 1, 0, 3]]
            if not bgra.any():
                continue
            planar = bgra.transpose(2, 0, 1).tobytes()  # compressed tiles are planar, raw ones not
            blob = b"\x01" + lzf_compress(planar) if (x // tw) % 2 == 0 else b"\x00" + bgra.tobytes()
            tiles.append(f"{x},{y},LZF,{len(blob)}\n".encode() + blob)
    head = f"VERSION 2\nTILEWIDTH {tw}\nTILEHEIGHT {th}\nPIXELSIZE 4\nDATA {len(tiles)}\n".encode()
    return head + b"".join(tiles)


def write_kra(path, *, colorspace="RGBA"):
    items = artfiles.parts()
    files = {}

    def leaf(k, name, rgba, x, y):
        files[f"char/layers/layer{k}"] = tile_file(rgba)
        return (f'<layer name="{name}" filename="layer{k}" nodetype="paintlayer" visible="1" opacity="255" '
                f'x="{x}" y="{y}" compositeop="normal" colorspacename="{colorspace}"/>')
    xml = artfiles.tree_xml(items, lambda g: f'<layer name="{g}" nodetype="grouplayer" visible="1" '
                            'opacity="255"><layers>', "</layers></layer>", leaf)
    files["char/layers/sketch"] = tile_file(artfiles.sketch())
    xml.append('<layer name="sketch" filename="sketch" nodetype="paintlayer" visible="0" x="0" y="0"/>')
    w, h = artfiles.CANVAS
    doc = (f'<?xml version="1.0"?><DOC><IMAGE name="char" width="{w}" height="{h}" colorspacename="RGBA">'
           f'<layers>{"".join(xml)}</layers></IMAGE></DOC>')
    buf = io.BytesIO()
    Image.fromarray(artfiles.composite([(a, o) for _, _, a, o in items])).save(buf, format="PNG")
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("mimetype", "application/x-krita")
        z.writestr("maindoc.xml", doc)
        z.writestr("mergedimage.png", buf.getvalue())
        for k, v in files.items():
            z.writestr(k, v, compress_type=zipfile.ZIP_DEFLATED)


def check_parts(art):
    """The seven parts, visible, and the sketch under them kept hidden (issue 32)."""
    assert [lay.name for lay in art.layers] == ["sketch"] + NAMES
    sketch, *parts = art.layers
    assert not sketch.visible and all(lay.visible for lay in parts)
    assert (sketch.rgba[..., 3] > 0).any() and sketch.rgba.shape[0] <= artfiles.sketch().shape[0]
    for lay, (_, _, rgba, (x, y)) in zip(parts, artfiles.parts()):
        rows, cols = np.nonzero(rgba[..., 3])
        assert lay.offset == (x + cols.min(), y + rows.min()), lay.name
        crop = rgba[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
        assert np.array_equal(lay.rgba[..., 3], crop[..., 3]), lay.name
        on = crop[..., 3] > 0
        assert np.array_equal(lay.rgba[on, :3], crop[on, :3]), lay.name
    assert art.hidden == ["sketch"]


def test_kra_layers_are_read_from_their_tiles(tmp_path):
    path = tmp_path / "char.kra"
    write_kra(path)
    check_parts(read_layered(str(path)))


def test_kra_in_another_colour_depth_is_its_merged_image(tmp_path):
    path = tmp_path / "deep.kra"
    write_kra(path, colorspace="RGBA16")
    art = read_layered(str(path))
    assert [lay.name for lay in art.layers if lay.visible] == ["image"]
    assert any("merged image" in n for n in art.notes)
    assert sum("RGBA16" in n for n in art.notes) == 7


def test_ora_layers(tmp_path):
    path = tmp_path / "char.ora"
    artfiles.write_ora(str(path))
    check_parts(read_layered(str(path)))


def ora(tmp_path, layers_xml, files, name="t.ora", w=50, h=40):
    path = tmp_path / name
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("mimetype", "image/openraster")
        z.writestr("stack.xml", f'<image w="{w}" h="{h}"><stack>{layers_xml}</stack></image>')
        for k, v in files.items():
            z.writestr(k, v)
    return str(path)


def png(colour, size=(10, 10), alpha=255):
    a = np.zeros((size[1], size[0], 4), np.uint8)
    a[..., :3], a[..., 3] = colour, alpha
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG")
    return buf.getvalue()


def test_ora_opacity_blend_merge_and_ignore(tmp_path):
    xml = ('<layer name="notes [ignore]" src="n.png"/>'
           '<stack name="arm [merge]" opacity="0.5"><layer name="a" src="a.png" x="20" y="0"/>'
           '<layer name="b" src="b.png" x="25" y="5"/></stack>'
           '<layer name="shade" src="s.png" composite-op="svg:multiply" x="0" y="0"/>'
           '<layer name="body" src="body.png" x="0" y="0" opacity="1.0"/>')
    path = ora(tmp_path, xml, {"n.png": png((1, 1, 1)), "a.png": png((0, 0, 255)), "b.png": png((0, 255, 0)),
                               "s.png": png((128, 128, 128), (5, 5)), "body.png": png((200, 100, 50))})
    check_body_and_arm(read_layered(path))


def check_body_and_arm(art):
    """A 10x10 body (200, 100, 50) multiplied by 128 grey on its 5x5 corner, and a merged
    half-opaque arm: a blue 10x10 at (20, 0) over a green one at (25, 5)."""
    assert [lay.name for lay in art.layers] == ["body", "arm"]
    body, arm = art.layers
    assert tuple(body.rgba[2, 2]) == (100, 50, 25, 255) and tuple(body.rgba[7, 7]) == (200, 100, 50, 255)
    assert arm.offset == (20, 0) and arm.rgba.shape[:2] == (15, 15)
    # the file lists the top first: a (blue) is over b (green)
    assert tuple(arm.rgba[2, 2]) == (0, 0, 255, 128) and tuple(arm.rgba[12, 12]) == (0, 255, 0, 128)
    assert tuple(arm.rgba[7, 7]) == (0, 0, 255, 128) and arm.rgba[12, 2, 3] == 0
    assert any("multiply baked into 'body'" in n for n in art.notes)


@pytest.mark.parametrize("make, words", [
    (lambda t: (t / "x.ora").write_bytes(b"PK\x03\x04 broken") and str(t / "x.ora"), "not a zip archive"),
    (lambda t: ora(t, "", {}, w=0), "document: empty"),
    (lambda t: ora(t, '<layer name="a" src="missing.png"/>', {}), "no 'missing.png'"),
    (lambda t: ora(t, '<layer name="a" src="a.png"/>', {"a.png": b"not a png"}), "a.png: not a readable image"),
    (lambda t: ora(t, '<layer name="a" src="a.png" visibility="hidden"/>', {"a.png": png((1, 2, 3))}),
     "every layer is hidden"),
    (lambda t: ora(t, '<layer name="a" src="a.png" x="0" y="0"/>', {"a.png": png((1, 2, 3), (20000, 1))}),
     "too large (20000x1"),
])
def test_bad_ora_is_one_error(tmp_path, make, words):
    with pytest.raises(ImageError, match=None) as e:
        read_layered(make(tmp_path))
    assert words in str(e.value) and "\n" not in str(e.value)


def test_xml_entities_are_refused(tmp_path):
    path = tmp_path / "bomb.ora"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("stack.xml", '<?xml version="1.0"?><!DOCTYPE x [<!ENTITY a "aaaa">]><image w="1" h="1"/>')
    with pytest.raises(ImageError, match="entity"):
        read_layered(str(path))


def test_zip_members_are_read_with_a_bound(tmp_path):
    path = tmp_path / "z.zip"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("big", b"\0" * 100_000, compress_type=zipfile.ZIP_DEFLATED)
    with zipfile.ZipFile(path) as z:
        with pytest.raises(ImageError, match="too large"):
            member(z, "big", 1000, str(path))
        assert len(member(z, "big", 100_000, str(path))) == 100_000
    # a header that lies about the size: reading stops at the bound all the same
    data = bytearray(path.read_bytes())
    for sig in (b"PK\x03\x04", b"PK\x01\x02"):
        at = data.find(sig)
        field = 22 if sig == b"PK\x03\x04" else 24
        data[at + field:at + field + 4] = (500).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    with zipfile.ZipFile(path) as z:
        with pytest.raises(ImageError, match="big"):
            member(z, "big", 1000, str(path))


def kra(tmp_path, layers_xml, files, w=50, h=40):
    path = tmp_path / "t.kra"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("maindoc.xml", f'<DOC><IMAGE name="d" width="{w}" height="{h}"><layers>{layers_xml}'
                                  '</layers></IMAGE></DOC>')
        for k, v in files.items():
            z.writestr(f"d/layers/{k}", v)
    return str(path)


def kra_layer(name, file, x=0, y=0, op="normal"):
    return (f'<layer name="{name}" filename="{file}" nodetype="paintlayer" visible="1" opacity="255" '
            f'x="{x}" y="{y}" compositeop="{op}" colorspacename="RGBA"/>')


def solid(colour, w=10, h=10):
    a = np.zeros((h, w, 4), np.uint8)
    a[..., :3], a[..., 3] = colour, 255
    return tile_file(a)


def test_kra_merge_group_and_blend_mode(tmp_path):
    xml = ('<layer name="arm [merge]" nodetype="grouplayer" visible="1" opacity="128"><layers>'
           + kra_layer("a", "a", 20, 0) + kra_layer("b", "b", 25, 5) + "</layers></layer>"
           + kra_layer("shade", "s", 0, 0, op="multiply") + kra_layer("body", "body"))
    path = kra(tmp_path, xml, {"a": solid((0, 0, 255)), "b": solid((0, 255, 0)), "s": solid((128, 128, 128), 5, 5),
                               "body": solid((200, 100, 50))})
    check_body_and_arm(read_layered(path))
