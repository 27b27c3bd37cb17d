"""Issue 30, the layered readers: bombs refused up front from headers (layers, pixels,
tile work), a KRA tile repeated many times decoded once, and every damaged ORA/KRA (an
encrypted member, coordinates such as 1e400, opacity "abc", groups nested 1000 deep,
stack.xml in UTF-16 with an entity) one error line through ``puppet init``: exit 2, no
traceback, nothing written, every file as it was; each run bounded in time and memory."""
from __future__ import annotations

import io
import os
import random
import re
import resource
import struct
import subprocess
import sys
import time
import zipfile
import zlib

import numpy as np
import pytest

from puppet.errors import ImageError
from puppet.imaging.layered import art as art_module
from puppet.imaging.layered import kra as kra_module
from puppet.imaging.layered import read_layered
from tests import artfiles
from tests.conftest import ROOT
from tests.fstree import snapshot
from tests.imaging.test_layered_zip import kra, kra_layer, lzf_compress, ora, png, solid, write_kra

MEMORY = 2 << 30  # the child's address space: a bomb decoded would need far more


def limited():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def init(tmp_path, art, timeout=30, *extra):
    """``puppet init ART -o S.json`` in a fresh process under a memory cap; returns the
    process and the seconds it took."""
    t = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "puppet", "init", str(art), "-o", str(tmp_path / "s.json"), *extra],
                       capture_output=True, text=True, timeout=timeout, cwd=ROOT, preexec_fn=limited,
                       env=dict(os.environ, PYTHONPATH=ROOT))
    return r, time.monotonic() - t


def refused(tmp_path, art, *words, timeout=30, seconds=10.0) -> str:
    """Init refuses ``art`` in one line holding ``words``, within ``seconds``, leaving the
    folder as it was."""
    before = snapshot(str(tmp_path))
    r, took = init(tmp_path, art, timeout)
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("puppet: error: "), r.stderr[-2000:]
    assert "Traceback" not in r.stderr and os.path.basename(str(art)) in lines[0]
    for w in words:
        assert w in lines[0], lines[0]
    assert snapshot(str(tmp_path)) == before
    assert took < seconds, took
    return lines[0]


# -- builders ----------------------------------------------------------------------------
def png_header(w: int, h: int) -> bytes:
    """A PNG with a header and no pixel data: its size can be read, its pixels cannot."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", b"x") + chunk(b"IEND", b"")


def tiles(count_xy, blob: bytes, tw=64, th=64) -> bytes:
    """A Krita tile file: ``blob`` (flag byte included) at every (x, y) of ``count_xy``."""
    head = f"VERSION 2\nTILEWIDTH {tw}\nTILEHEIGHT {th}\nPIXELSIZE 4\nDATA {len(count_xy)}\n".encode()
    return head + b"".join(f"{x},{y},LZF,{len(blob)}\n".encode() + blob for x, y in count_xy)


def slow_tile() -> bytes:
    """An LZF tile of 64x64 that the pure-Python decoder takes long over: one literal then
    back-references of three bytes, 5461 tokens (about 20 ms)."""
    n = 64 * 64 * 4
    body = bytes([0, 7]) + bytes([1 << 5, 0]) * ((n - 1) // 3)
    return b"\x01" + body


def deflated(path: str) -> str:
    """The zip at ``path`` rewritten with every member deflated (as Krita writes them)."""
    with zipfile.ZipFile(path) as z:
        members = [(n, z.read(n)) for n in z.namelist()]
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for n, data in members:
            z.writestr(n, data)
    return path


def nested_ora(tmp_path, depth: int, name="deep.ora"):
    xml = '<stack name="g">' * depth + '<layer name="a" src="a.png" x="1" y="1"/>' + "</stack>" * depth
    return ora(tmp_path, xml, {"a.png": png((10, 20, 30))}, name=name)


def nested_kra(tmp_path, depth: int):
    group = '<layer name="g" nodetype="grouplayer" visible="1" opacity="255"><layers>'
    xml = group * depth + kra_layer("a", "a", 1, 1) + "</layers></layer>" * depth
    return kra(tmp_path, xml, {"a": solid((10, 20, 30))})


def encrypted(path):
    """Mark every member of the zip at ``path`` as encrypted (flag bit 0), as a
    password-protected archive has it."""
    data = bytearray(open(path, "rb").read())
    for sig, at in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        i = data.find(sig)
        while i >= 0:
            data[i + at] |= 1
            i = data.find(sig, i + 4)
    open(path, "wb").write(bytes(data))
    return path


# -- bombs: refused up front, quickly, in little memory ----------------------------------
def test_kra_with_60_layers_of_8192_on_one_tile_file_is_refused_at_once(tmp_path):
    blob = b"\x01" + lzf_compress(bytes(64 * 64 * 4))
    xy = [(x, y) for y in range(0, 8192, 64) for x in range(0, 8192, 64)]
    layers = "".join(kra_layer(f"l{k}", "t") for k in range(60))
    art = deflated(kra(tmp_path, layers, {"t": tiles(xy, blob)}, w=8192, h=8192))
    assert os.path.getsize(art) < 400_000
    refused(tmp_path, art, "60 layers of 8192x8192", "in all, more than the limit of", "536870912 pixels")


def test_ora_with_100_layers_of_32_mpx_is_refused_from_the_png_headers(tmp_path):
    layers = "".join(f'<layer name="l{k}" src="a.png"/>' for k in range(100))
    art = ora(tmp_path, layers, {"a.png": png_header(8000, 4000)}, w=8000, h=4000)
    assert os.path.getsize(art) < 4000
    refused(tmp_path, art, "100 layers of 8000x4000", "3.2 Gpx in all", "536870912 pixels")


def test_kra_listing_a_tile_over_and_over_is_refused_by_the_decode_work(tmp_path):
    blob = b"\x01" + lzf_compress(bytes(256 * 256 * 4))  # 8200 times at one place: 537 Mpx to decode
    art = deflated(kra(tmp_path, kra_layer("a", "t"), {"t": tiles([(0, 0)] * 8200, blob, 256, 256)}))
    refused(tmp_path, art, "tiles of 537.4 Mpx to decode in all", "more than the limit")


def test_too_many_layers_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(art_module, "MAX_LAYERS", 5)
    layers = "".join(f'<layer name="l{k}" src="a.png"/>' for k in range(6))
    with pytest.raises(ImageError, match="6 layers, more than the limit of 5 layers"):
        read_layered(ora(tmp_path, layers, {"a.png": png((1, 2, 3))}))


def test_a_professional_document_is_within_the_totals():
    totals = art_module.Totals("big.psd", (4000, 4000))
    for k in range(30):
        totals.add(4000, 4000, f"layer {k}")
    totals.check()  # 31 x 16 Mpx: within
    for k in range(3):
        totals.add(4000, 4000, f"one more {k}")
    with pytest.raises(ImageError, match="33 layers of 4000x4000 on a 4000x4000 canvas = 544.0 Mpx in all"):
        totals.check()


# -- the CPU bomb: a tile repeated is decoded once -----------------------------------------
def test_kra_repeating_one_slow_tile_imports_in_seconds(tmp_path):
    xy = [(x, y) for y in range(0, 1536, 64) for x in range(0, 1536, 64)]  # 576 copies: 10 s decoded each
    art = deflated(kra(tmp_path, kra_layer("a", "t"), {"t": tiles(xy, slow_tile())}, w=1536, h=1536))
    r, took = init(tmp_path, art, 60)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert took < 10, took  # decoded once a copy: 576 x 20 ms, over 11 s
    assert os.path.exists(tmp_path / "s-layers" / "a.png")


def test_lzf_work_is_bounded(tmp_path, monkeypatch):
    monkeypatch.setattr(kra_module, "MAX_LZF_TOKENS", 2000)
    rng = np.random.default_rng(1)
    distinct = [b"\x01" + lzf_compress(rng.integers(0, 3, 64 * 64 * 4, dtype=np.uint8).tobytes())
                for _ in range(8)]
    data = b"".join(f"{64 * k},0,LZF,{len(b)}\n".encode() + b for k, b in enumerate(distinct))
    head = f"VERSION 2\nTILEWIDTH 64\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA {len(distinct)}\n".encode()
    path = kra(tmp_path, kra_layer("a", "t"), {"t": head + data}, w=600, h=64)
    with pytest.raises(ImageError, match="decode work: more than the limit of 2000 LZF tokens"):
        read_layered(path)


# -- every damaged ORA/KRA: one line ----------------------------------------------------
@pytest.mark.parametrize("value", ["1e400", "-inf", "1e300"])
def test_ora_coordinates_that_are_no_coordinates(tmp_path, value):
    art = ora(tmp_path, f'<layer name="arm" src="a.png" x="{value}"/>', {"a.png": png((1, 2, 3))})
    refused(tmp_path, art, f"stack.xml: layer 'arm': x='{value}' is not a number")


@pytest.mark.parametrize("value", ["1e400", "-inf", "1e300", "nan", "abc", "2000000"])
def test_every_coordinate_is_checked(tmp_path, value):
    art = ora(tmp_path, f'<stack name="g" y="{value}"><layer name="arm" src="a.png"/></stack>',
              {"a.png": png((1, 2, 3))})
    with pytest.raises(ImageError, match=f"stack.xml: stack 'g': y='{value}' is not a number from -1048576"):
        read_layered(art)


@pytest.mark.parametrize("value", ["1e400", "-inf", "1e300"])
def test_kra_coordinates_that_are_no_coordinates(tmp_path, value):
    xml = kra_layer("arm", "a").replace('x="0"', f'x="{value}"')
    art = kra(tmp_path, xml, {"a": solid((1, 2, 3))})
    refused(tmp_path, art, f"maindoc.xml: layer 'arm': x='{value}' is not a number")


@pytest.mark.parametrize("value", ["1e400", "-1", "abc"])
def test_document_sizes_that_are_no_sizes(tmp_path, value):
    art = ora(tmp_path, "", {})
    with zipfile.ZipFile(art, "w") as z:
        z.writestr("stack.xml", f'<image w="{value}" h="10"><stack/></image>')
    refused(tmp_path, art, f"w='{value}' is not a whole number")


@pytest.mark.parametrize("value", ["abc", "0.5", "1e400", "-3"])
def test_kra_opacity_that_is_no_opacity(tmp_path, value):
    xml = kra_layer("arm", "a").replace('opacity="255"', f'opacity="{value}"')
    art = kra(tmp_path, xml, {"a": solid((1, 2, 3))})
    refused(tmp_path, art, f"maindoc.xml: layer 'arm': opacity='{value}' is not a whole number from 0 to 255")


def test_ora_opacity_out_of_range_is_clamped_and_nan_refused(tmp_path):
    art = read_layered(ora(tmp_path, '<layer name="a" src="a.png" opacity="1.5"/>', {"a.png": png((1, 2, 3))}))
    assert art.layers[0].rgba[0, 0, 3] == 255
    art = ora(tmp_path, '<layer name="a" src="a.png" opacity="nan"/>', {"a.png": png((1, 2, 3))}, name="n.ora")
    refused(tmp_path, art, "opacity='nan' is not a number from 0 to 1")


@pytest.mark.parametrize("make", [lambda t: encrypted(ora(t, '<layer name="a" src="a.png"/>', {"a.png": png((1, 2, 3))})),
                                  lambda t: encrypted(kra(t, kra_layer("a", "a"), {"a": solid((1, 2, 3))}))],
                         ids=["ora", "kra"])
def test_encrypted_members_are_one_line(tmp_path, make):
    refused(tmp_path, make(tmp_path), "encrypted (password-protected members are not read)")


def test_a_damaged_deflate_stream_is_one_line(tmp_path):
    art = tmp_path / "d.ora"
    text = '<image w="20" h="20"><stack>' + '<layer name="a" src="a.png"/>' * 400 + "</stack></image>"
    with zipfile.ZipFile(art, "w") as z:
        z.writestr("stack.xml", text, compress_type=zipfile.ZIP_DEFLATED)
    data = bytearray(art.read_bytes())
    data[60:80] = b"\xff" * 20  # inside stack.xml's compressed data
    art.write_bytes(bytes(data))
    refused(tmp_path, art, "stack.xml: cannot be read")


@pytest.mark.parametrize("make", [nested_ora, nested_kra], ids=["ora", "kra"])
def test_groups_nested_1000_deep_are_one_line(tmp_path, make):
    refused(tmp_path, make(tmp_path, 1000), "groups nested more than 256 deep")


@pytest.mark.parametrize("make", [nested_ora, nested_kra], ids=["ora", "kra"])
def test_groups_nested_200_deep_are_read(tmp_path, make):
    art = read_layered(make(tmp_path, 200))
    assert [lay.name for lay in art.layers] == ["g/" * 200 + "a"]


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be", "utf-32", "utf-8-sig"])
def test_an_entity_in_any_encoding_is_refused(tmp_path, encoding):
    text = (f'<?xml version="1.0" encoding="{encoding.removesuffix("-sig").upper()}"?>'
            '<!DOCTYPE image [<!ENTITY e "EVIL">]><image w="20" h="20"><stack>'
            '<layer name="&e;" src="a.png"/></stack></image>')
    art = ora(tmp_path, "", {"a.png": png((1, 2, 3))})
    with zipfile.ZipFile(art, "w") as z:
        z.writestr("stack.xml", text.encode(encoding))
        z.writestr("a.png", png((1, 2, 3)))
    refused(tmp_path, art, "stack.xml: XML entity declarations are not accepted")


def test_stack_xml_in_utf16_is_read(tmp_path):
    text = ('<?xml version="1.0" encoding="UTF-16"?><image w="20" h="20"><stack>'
            '<layer name="bras é" src="a.png"/></stack></image>')
    art = ora(tmp_path, "", {})
    with zipfile.ZipFile(art, "w") as z:
        z.writestr("stack.xml", text.encode("utf-16"))
        z.writestr("a.png", png((1, 2, 3)))
    assert [lay.name for lay in read_layered(art).layers] == ["bras é"]


def test_xml_in_an_unknown_encoding_is_one_line(tmp_path):
    art = ora(tmp_path, "", {})
    with zipfile.ZipFile(art, "w") as z:
        z.writestr("stack.xml", b'<?xml version="1.0" encoding="no-such-codec"?><image w="2" h="2"/>')
    refused(tmp_path, art, "stack.xml: unknown XML encoding 'no-such-codec'")


# -- a small campaign: damaged copies of a real ORA and KRA are read or refused in one line --
_VALUES = ["1e400", "-inf", "inf", "nan", "1e300", "abc", "0.5", "-3", "", " ", "0x10", "٣", "255.0", "1e5",
           "99999999999999999999999", "-1048577"]


def _damaged(src: str, rnd) -> bytes:
    """A copy of the zip ``src`` with attribute values, bytes, a member's end or the XML's
    encoding changed."""
    with zipfile.ZipFile(src) as z:
        members = {n: z.read(n) for n in z.namelist()}
    xml = "stack.xml" if "stack.xml" in members else "maindoc.xml"
    kind = rnd.randrange(5)
    if kind <= 1:
        text = members[xml].decode()
        for _ in range(rnd.randint(1, 3)):
            m = rnd.choice(list(re.finditer(r'(\w[\w-]*)="([^"]*)"', text)))
            text = text[:m.start(2)] + rnd.choice(_VALUES) + text[m.end(2):]
        members[xml] = text.encode()
    elif kind == 2:
        name = rnd.choice(list(members))
        b = bytearray(members[name])
        for _ in range(rnd.randint(1, 20)):
            if b:
                b[rnd.randrange(len(b))] = rnd.randrange(256)
        members[name] = bytes(b)
    elif kind == 3:
        name = rnd.choice(list(members))
        members[name] = members[name][:rnd.randrange(len(members[name]) + 1)]
    else:
        members[xml] = members[xml].decode().encode(rnd.choice(["utf-16", "utf-16-be", "utf-32", "utf-8-sig"]))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for n, d in members.items():
            z.writestr(n, d)
    return buf.getvalue()


def test_damaged_ora_and_kra_files_are_read_or_one_line(tmp_path):
    artfiles.write_ora(str(tmp_path / "base.ora"))
    write_kra(str(tmp_path / "base.kra"))
    rnd, outcomes = random.Random(1), {"read": 0, "refused": 0}
    for i in range(50):  # before issue 30: 17 tracebacks in 300 such cases
        src = tmp_path / rnd.choice(["base.ora", "base.kra"])
        path = tmp_path / f"case{i}{src.suffix}"
        path.write_bytes(_damaged(str(src), rnd))
        try:
            read_layered(str(path))
            outcomes["read"] += 1
        except ImageError as e:
            assert "\n" not in str(e) and str(path) in str(e), str(e)
            outcomes["refused"] += 1
    assert outcomes["read"] and outcomes["refused"]


@pytest.mark.parametrize("kind", ["psd", "ora", "kra"])
def test_every_reader_counts_its_layers_against_the_totals(tmp_path, monkeypatch, kind):
    path = str(tmp_path / f"char.{kind}")
    {"psd": artfiles.write_psd, "ora": artfiles.write_ora, "kra": write_kra}[kind](path)
    read_layered(path)  # within the limits as they are
    monkeypatch.setattr(art_module, "MAX_TOTAL_PIXELS", 300_000)
    with pytest.raises(ImageError, match=r"layers of up to \d+x\d+ on a \d+x\d+ canvas = .* in all, more than the "
                                         r"limit of 0.3 Mpx \(300000 pixels\)"):
        read_layered(path)
