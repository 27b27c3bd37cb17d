"""PNGs read by OpenCV (the fast path of decode_image) give exactly what Pillow gives."""
from __future__ import annotations

import glob
import io
import os
import struct
import zlib

import numpy as np
import pytest
from PIL import Image, PngImagePlugin

from puppet.errors import ImageError
from puppet.imaging import io as pio
from puppet.imaging.io import decode_image, save_png

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def by_pillow(path: str) -> tuple[np.ndarray, bool]:
    with pio._opened(path, None, None) as (_, _, im, _, _):
        im.load()
        return pio.pillow_to_rgba(im)


def plain(path: str):
    with open(path, "rb") as f:
        return pio._plain_png(f)


def write(tmp_path, name: str, data: bytes) -> str:
    p = str(tmp_path / name)
    with open(p, "wb") as f:
        f.write(data)
    return p


def png(im: Image.Image, **kw) -> bytes:
    b = io.BytesIO()
    im.save(b, format="PNG", **kw)
    return b.getvalue()


def chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def with_text(im: Image.Image) -> bytes:
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", "a painter")
    return png(im, pnginfo=info)


def with_chunk(data: bytes, kind: bytes, body: bytes) -> bytes:
    return data[:33] + chunk(kind, body) + data[33:]  # right after IHDR


def test_bundled_pngs_decode_as_pillow_reads_them():
    paths = sorted(glob.glob(os.path.join(ROOT, "assets", "**", "*.[pP][nN][gG]"), recursive=True))
    assert len(paths) > 20
    fast = 0
    for p in paths:
        rgba, alpha = decode_image(p)
        want, want_alpha = by_pillow(p)
        assert np.array_equal(rgba, want) and alpha == want_alpha, p
        fast += plain(p) is not None
    assert fast >= 8  # the T-rex's parts at least (IHDR, pHYs, IDAT, IEND)
    for p in glob.glob(os.path.join(ROOT, "assets", "trex", "*.PNG")):
        assert plain(p) is not None, p


rng = np.random.default_rng(3)
RGB = rng.integers(0, 256, (23, 31, 3), dtype=np.uint8)
RGB[:4, :4] = (10, 20, 30)
GREY = rng.integers(0, 256, (23, 31), dtype=np.uint8)


@pytest.mark.parametrize("name, data", [
    ("grey", png(Image.fromarray(GREY))),
    ("grey1", png(Image.fromarray(GREY > 128))),
    ("rgb", png(Image.fromarray(RGB))),
    ("rgb-key", png(Image.fromarray(RGB), transparency=(10, 20, 30))),
    ("grey-alpha", png(Image.fromarray(rng.integers(0, 256, (23, 31, 2), dtype=np.uint8), "LA"))),
    ("rgba", png(Image.fromarray(rng.integers(0, 256, (23, 31, 4), dtype=np.uint8)))),
    ("palette", png(Image.fromarray(RGB).quantize(40))),
    ("palette-key", png(Image.fromarray(RGB).quantize(40), transparency=5)),
    ("palette4", png(Image.fromarray(RGB).quantize(12), bits=4)),
    ("palette2", png(Image.fromarray(RGB).quantize(4), bits=2)),
    ("srgb", with_chunk(png(Image.fromarray(RGB)), b"sRGB", b"\x00")),
])
def test_plain_formats_are_read_by_opencv_as_pillow_reads_them(tmp_path, name, data):
    p = write(tmp_path, name + ".png", data)
    got = plain(p)
    assert got is not None
    want, want_alpha = by_pillow(p)
    assert np.array_equal(got[0], want) and got[1] == want_alpha
    assert np.array_equal(decode_image(p)[0], want)


@pytest.mark.parametrize("name, data", [
    ("grey-key", png(Image.fromarray(GREY), transparency=77)),  # OpenCV ignores a grey key
    ("text", with_text(Image.fromarray(RGB))),
    ("gamma", with_chunk(png(Image.fromarray(RGB)), b"gAMA", struct.pack(">I", 45455))),
    ("profile", with_chunk(png(Image.fromarray(RGB)), b"iCCP", b"x\0\0" + zlib.compress(b"y" * 99))),
    ("exif", with_chunk(png(Image.fromarray(RGB)), b"eXIf", b"MM\0*\0\0\0\x08\0\0")),
    ("rgba-key", with_chunk(png(Image.fromarray(np.dstack([RGB, RGB[..., :1]]))), b"tRNS", b"\0" * 6)),
    ("grey16", png(Image.fromarray(GREY.astype(np.uint16) * 257))),
])
def test_other_pngs_go_to_pillow(tmp_path, name, data):
    p = write(tmp_path, name + ".png", data)
    assert plain(p) is None
    if name not in ("profile", "exif", "rgba-key"):  # Pillow reads these as it can
        assert np.array_equal(decode_image(p)[0], by_pillow(p)[0])


def test_damaged_pngs_are_left_to_pillow(tmp_path):
    """A bad CRC or a cut file is not read by OpenCV: Pillow's path decides (it reads a
    bad IDAT CRC as it can, and refuses a cut file with its message)."""
    good = png(Image.fromarray(RGB))
    bad_crc = bytearray(good)
    bad_crc[-20] ^= 0xFF  # the last IDAT's last byte: its CRC no longer matches
    p = write(tmp_path, "crc.png", bytes(bad_crc))
    assert plain(p) is None
    assert np.array_equal(decode_image(p)[0], by_pillow(p)[0])
    p = write(tmp_path, "cut.png", good[:-30])
    assert plain(p) is None
    with pytest.raises(ImageError, match="cut.png"):
        decode_image(p)


@pytest.mark.parametrize("channels", [3, 4])
def test_save_png_round_trips(tmp_path, channels):
    a = np.random.default_rng(channels).integers(0, 256, (13, 17, channels), dtype=np.uint8)
    p = str(tmp_path / "o.png")
    save_png(p, a)
    back = np.asarray(Image.open(p))
    assert back.shape == a.shape and np.array_equal(back, a)
    with pytest.raises(ValueError):
        save_png(str(tmp_path / "g.png"), a[..., 0])
