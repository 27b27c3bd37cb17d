"""Issue 8, part 6: images decode as they look (exact values on known pixels), and a
FIFO or device given as an image is refused at once."""
from __future__ import annotations

import os
import signal
import struct
import zlib

import numpy as np
import pytest
from PIL import Image, ImageOps

from puppet.errors import ImageError
from puppet.imaging.decode import orient, scale16, scale_float
from puppet.imaging.io import decode_image, load_mask_image, load_rgba


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def write_png(path, samples: np.ndarray, color_type: int, bits: int, chunks=()) -> str:
    """A PNG written sample by sample (any bit depth and colour type), so the test knows
    exactly what the file holds. ``samples``: (h, w[, c]) ints."""
    a = np.asarray(samples)
    h, w = a.shape[:2]
    flat = a.reshape(h, -1)
    if bits == 16:
        rows = flat.astype(">u2").view(np.uint8).reshape(h, -1)
    elif bits == 8:
        rows = flat.astype(np.uint8)
    else:
        assert bits == 1
        rows = np.packbits(flat.astype(np.uint8), axis=1)
    raw = b"".join(b"\x00" + r.tobytes() for r in rows)
    ihdr = struct.pack(">IIBBBBB", w, h, bits, color_type, 0, 0, 0)
    body = b"".join(_chunk(k, d) for k, d in chunks)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + body + _chunk(b"IDAT", zlib.compress(raw))
                + _chunk(b"IEND", b""))
    return str(path)


V16 = np.array([0, 128, 129, 447, 32767, 32896, 65535])
V8 = np.array([0, 0, 1, 2, 127, 128, 255])  # round(v / 257), by hand


def test_scale16_rounds_not_truncates():
    assert scale16(V16).tolist() == V8.tolist()
    v = np.arange(65536)
    assert (scale16(v) == np.floor(v / 257 + 0.5)).all()
    assert (scale16(v).astype(int) != (v >> 8)).sum() > 16000  # the high byte is another answer for 1/4


def test_scale_float():
    assert scale_float(np.array([0.0, 0.5, 1.0, 2.0, -1.0, np.nan, 0.2])).tolist() == [0, 128, 255, 255, 0, 0, 51]


def test_16bit_grey_png(tmp_path):
    p = write_png(tmp_path / "g.png", V16[None], 0, 16)
    rgba, has_alpha = decode_image(p)
    assert rgba[0, :, 0].tolist() == V8.tolist() and (rgba[..., 0] == rgba[..., 2]).all()
    assert (rgba[..., 3] == 255).all() and not has_alpha
    with Image.open(p) as im:  # Pillow's naive conversion clips: 447 would be 255
        assert np.array(im.convert("RGBA"))[0, 3, 0] == 255 and rgba[0, 3, 0] == 2


def test_16bit_grey_with_transparent_key(tmp_path):
    p = write_png(tmp_path / "g.png", V16[None], 0, 16, [(b"tRNS", struct.pack(">H", 447))])
    rgba, has_alpha = decode_image(p)
    assert has_alpha and rgba[0, :, 3].tolist() == [255, 255, 255, 0, 255, 255, 255]
    assert load_mask_image(p)[0].tolist() == [True, True, True, False, True, True, True]


def test_16bit_grey_alpha(tmp_path):
    la = np.stack([V16, V16[::-1]], axis=-1)[None]
    rgba, has_alpha = decode_image(write_png(tmp_path / "la.png", la, 4, 16))
    assert has_alpha
    assert rgba[0, :, 1].tolist() == V8.tolist() and rgba[0, :, 3].tolist() == V8[::-1].tolist()


@pytest.mark.parametrize("channels", [3, 4])
def test_16bit_colour_png(tmp_path, channels):
    a = np.stack([V16, V16[::-1], np.full_like(V16, 447), V16[::-1]][:channels], axis=-1)[None]
    p = write_png(tmp_path / "c.png", a, 6 if channels == 4 else 2, 16)
    rgba, has_alpha = decode_image(p)
    assert has_alpha == (channels == 4)
    assert rgba[0, :, 0].tolist() == V8.tolist() and rgba[0, :, 1].tolist() == V8[::-1].tolist()
    assert (rgba[0, :, 2] == 2).all()
    assert rgba[0, :, 3].tolist() == (V8[::-1].tolist() if channels == 4 else [255] * 7)
    with Image.open(p) as im:  # Pillow keeps the high byte: 447 -> 1
        assert np.array(im.convert("RGBA"))[0, 0, 2] == 1


def test_16bit_colour_with_transparent_key(tmp_path):
    a = np.array([[[1, 2, 3], [447, 447, 447], [1, 2, 4]]])
    p = write_png(tmp_path / "k.png", a, 2, 16, [(b"tRNS", struct.pack(">HHH", 1, 2, 3))])
    rgba, has_alpha = decode_image(p)
    assert has_alpha and rgba[0, :, 3].tolist() == [0, 255, 255]  # only the exact 16-bit key
    assert rgba[0, 1, :3].tolist() == [2, 2, 2]


def test_palette_with_transparency(tmp_path):
    pal = bytes([255, 0, 0, 0, 255, 0, 0, 0, 255])
    idx = np.array([[0, 1, 2, 1]])
    p = write_png(tmp_path / "p.png", idx, 3, 8, [(b"PLTE", pal), (b"tRNS", bytes([255, 100]))])
    rgba, has_alpha = decode_image(p)
    assert has_alpha
    assert rgba[0].tolist() == [[255, 0, 0, 255], [0, 255, 0, 100], [0, 0, 255, 255], [0, 255, 0, 100]]
    with Image.open(p) as im:
        assert (np.array(im.convert("RGBA")) == rgba).all()


def test_one_bit_and_grey_alpha(tmp_path):
    rgba, _ = decode_image(write_png(tmp_path / "b.png", np.array([[1, 0, 1, 1, 0, 0, 0, 0, 1]]), 0, 1))
    assert rgba[0, :, 0].tolist() == [255, 0, 255, 255, 0, 0, 0, 0, 255] and (rgba[..., 3] == 255).all()
    la = np.array([[[10, 0], [20, 128], [30, 255]]])
    rgba, has_alpha = decode_image(write_png(tmp_path / "la.png", la, 4, 8))
    assert has_alpha and rgba[0].tolist() == [[10, 10, 10, 0], [20, 20, 20, 128], [30, 30, 30, 255]]


def _cmyk_formula(c):
    c = np.asarray(c, float)
    return np.round((255 - c[..., :3]) * (255 - c[..., 3:4]) / 255)


CMYK = np.array([[[0, 0, 0, 0], [255, 0, 0, 0], [0, 128, 0, 64], [30, 60, 90, 120]]], np.uint8)


def test_cmyk_tiff_exact(tmp_path):
    p = str(tmp_path / "c.tif")
    Image.fromarray(CMYK, "CMYK").save(p)
    rgba, has_alpha = decode_image(p)
    assert not has_alpha
    assert np.abs(rgba[0, :, :3] - _cmyk_formula(CMYK[0])).max() <= 1
    assert rgba[0, 0, :3].tolist() == [255, 255, 255] and rgba[0, 1, :3].tolist() == [0, 255, 255]


def test_cmyk_jpeg(tmp_path):
    """Flat 16x16 blocks (JPEG is lossy: compare block centres within a few levels)."""
    big = np.repeat(np.repeat(CMYK, 16, axis=0), 16, axis=1)
    p = str(tmp_path / "c.jpg")
    Image.fromarray(big, "CMYK").save(p, quality=100)
    with Image.open(p) as im:
        assert im.mode == "CMYK"
    rgba, _ = decode_image(p)
    centres = rgba[8, 8::16, :3].astype(int)
    assert np.abs(centres - _cmyk_formula(CMYK[0])).max() <= 4


def test_float_tiffs(tmp_path):
    f = np.array([[0.0, 0.5, 1.0, 2.0, -1.0, np.nan]], np.float32)
    p = str(tmp_path / "f.tif")
    Image.fromarray(f, "F").save(p)
    rgba, _ = decode_image(p)
    assert rgba[0, :, 0].tolist() == [0, 128, 255, 255, 0, 0]
    with Image.open(p) as im:  # Pillow reads floats as 0..255: 0.5 -> 0
        assert np.array(im.convert("L"))[0, 1] == 0
    import cv2

    c = np.zeros((2, 3, 3), np.float32)  # colour floats: Pillow cannot open these at all
    c[0, 1] = [0.25, 0.5, 1.0]           # R, G, B
    p = str(tmp_path / "c.tif")
    assert cv2.imwrite(p, c[..., ::-1])
    rgba, has_alpha = decode_image(p)
    assert rgba.shape == (2, 3, 4) and not has_alpha
    assert rgba[0, 1].tolist() == [64, 128, 255, 255] and rgba[1, 2].tolist() == [0, 0, 0, 255]


def test_16bit_tiffs(tmp_path):
    import cv2

    a = np.stack([V16, V16[::-1], np.full_like(V16, 447)], axis=-1)[None].astype(np.uint16)
    p = str(tmp_path / "c.tif")
    assert cv2.imwrite(p, a[..., ::-1])
    rgba, _ = decode_image(p)
    assert rgba[0, :, 0].tolist() == V8.tolist() and (rgba[0, :, 2] == 2).all()
    p = str(tmp_path / "g.tif")
    Image.fromarray(V16[None].astype(np.uint16)).save(p)
    assert decode_image(p)[0][0, :, 0].tolist() == V8.tolist()


def test_lab_tiff(tmp_path):
    # white, black, mid grey (a* and b* are signed bytes in Pillow and in TIFF: 0 is neutral)
    lab = np.array([[[255, 0, 0], [0, 0, 0], [135, 0, 0]]], np.uint8)
    p = str(tmp_path / "l.tif")
    Image.fromarray(lab, "LAB").save(p)
    rgba, _ = decode_image(p)
    assert np.abs(rgba[0, 0, :3].astype(int) - 255).max() <= 1 and rgba[0, 1, :3].max() <= 1
    g = rgba[0, 2, :3].astype(int)
    assert g.max() - g.min() <= 2 and 110 < g[0] < 140  # L* 53 is sRGB ~ 126


@pytest.mark.parametrize("orientation", range(1, 9))
def test_exif_orientation_as_viewers_show_it(tmp_path, orientation):
    a = np.arange(3 * 5 * 3, dtype=np.uint8).reshape(3, 5, 3) * 5
    im = Image.fromarray(a)
    exif = Image.Exif()
    exif[0x0112] = orientation
    p = str(tmp_path / "o.png")
    im.save(p, exif=exif)
    with Image.open(p) as im2:
        want = np.array(ImageOps.exif_transpose(im2).convert("RGB"))
    got = load_rgba(p)
    assert got.shape[:2] == want.shape[:2] and (got[..., :3] == want).all()
    assert (orient(a, orientation) == want).all()


def _no_hang(seconds: int = 10):
    def alarm(*_):
        raise TimeoutError("decoding a FIFO hung")
    signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_non_regular_files_refused_at_once(tmp_path, kind):
    p = str(tmp_path / "pipe.png")
    if kind == "fifo":
        os.mkfifo(p)
    else:
        p = "/dev/zero"
    _no_hang()
    try:
        for load in (load_rgba, load_mask_image):
            with pytest.raises(ImageError, match="not a regular file") as e:
                load(p, scene_file="s.json", json_path="layers[0].image")
            assert str(e.value).startswith("s.json: layers[0].image: image ")
    finally:
        signal.alarm(0)


def test_corrupt_tiff_message_is_one_line(tmp_path, capfd):
    """libtiff writes its complaints to the C stderr; they go into the error instead."""
    a = np.random.default_rng(0).integers(0, 256, (64, 64, 3), np.uint8)
    p = tmp_path / "c.tif"
    Image.fromarray(a).save(p, compression="tiff_lzw")
    b = bytearray(p.read_bytes())
    n = len(b)
    b[int(0.05 * n):int(0.2 * n)] = bytes(int(0.2 * n) - int(0.05 * n))
    p.write_bytes(bytes(b))
    with pytest.raises(ImageError, match="corrupt or truncated") as e:
        load_rgba(str(p))
    out, err = capfd.readouterr()
    assert err == "" and "\n" not in str(e.value)


def test_image_size_agrees_with_decoding(tmp_path):
    from puppet.imaging.io import image_size
    import cv2

    a = np.zeros((3, 5, 3), np.uint8)
    exif = Image.Exif()
    exif[0x0112] = 6  # rotated: shown 3 wide, 5 tall
    Image.fromarray(a).save(tmp_path / "o.png", exif=exif)
    assert image_size(str(tmp_path / "o.png")) == (3, 5) == load_rgba(str(tmp_path / "o.png")).shape[1::-1]
    assert cv2.imwrite(str(tmp_path / "f.tif"), np.zeros((4, 7, 3), np.float32))  # Pillow cannot open it
    assert image_size(str(tmp_path / "f.tif")) == (7, 4)
    os.mkfifo(tmp_path / "p.png")
    _no_hang()
    try:
        with pytest.raises(ImageError, match="not a regular file"):
            image_size(str(tmp_path / "p.png"))
    finally:
        signal.alarm(0)
