"""Every kind of bad input: exit status 2, one line naming the file and the JSON path,
no traceback, no output written."""
from __future__ import annotations

import json
import subprocess
import sys
import zlib
import struct

import numpy as np
import pytest

from puppet.cli import main
from tests.conftest import bar_image, bar_scene


def _png_header_only(path, w, h):
    """A valid PNG whose header claims w x h (1-bit grey) with a tiny compressed body."""
    def chunk(t, data):
        return struct.pack(">I", len(data)) + t + data + struct.pack(">I", zlib.crc32(t + data) & 0xFFFFFFFF)
    raw = zlib.compress(b"\x00" * (1 + (w + 7) // 8) * min(h, 4))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 1, 0, 0, 0, 0))
                + chunk(b"IDAT", raw) + chunk(b"IEND", b""))


def run_cli(capsys, args):
    rc = main(args)
    err = capsys.readouterr().err
    return rc, err


def set_in(d, path, value):
    keys = path.split("/")
    for k in keys[:-1]:
        d = d[int(k)] if isinstance(d, list) else d[k]
    last = keys[-1]
    if value is DELETE:
        if isinstance(d, list):
            del d[int(last)]
        else:
            del d[last]
    elif isinstance(d, list):
        d[int(last)] = value
    else:
        d[last] = value


DELETE = object()

# (what is changed, new value, JSON path the message must name, words the message must contain)
SCENE_CASES = [
    ("puppet", 2, "puppet", "version"),
    ("puppet", DELETE, "puppet", "required"),
    ("layers", DELETE, "layers", "required"),
    ("layers", [], "layers", "at least 1"),
    ("layerz", [], "layerz", "unknown key"),
    ("canvas", [120], "canvas", "2 items"),
    ("canvas", [120, -4], "canvas[1]", ">= 1"),
    ("canvas", [120, True], "canvas[1]", "number"),
    ("background", [255, 255, 300, 255], "background[2]", "<= 255"),
    ("background", "nowhere.png", "background", "no such file"),
    ("source", "missing.png", "source", "no such file"),
    ("layers/0/name", "", "layers[0].name", "empty"),
    ("layers/0/colour", "red", "layers[0].colour", "unknown key"),
    ("layers/0/image", "missing.png", "layers[0].image", "no such file"),
    ("layers/0/image", DELETE, "layers[0].image", "no image"),
    ("layers/0/offset", [1, "a"], "layers[0].offset[1]", "number"),
    ("layers/0/order", "front", "layers[0].order", "number"),
    ("layers/0/inpaint", "magic", "layers[0].inpaint", "not one of"),
    ("layers/0/mesh", {"max_area": 0}, "layers[0].mesh.max_area", ">= 0.5"),
    ("layers/0/mesh", {"min_angle": 40}, "layers[0].mesh.min_angle", "<= 34"),
    ("layers/0/mesh", {"density": 3}, "layers[0].mesh.density", "unknown key"),
    ("layers/0/exterior", {"beta": -1}, "layers[0].exterior.beta", "> 0"),
    ("layers/0/mask", "luma", "layers[0].mask", "not a mask"),
    ("layers/0/mask", {"rect": [0, 0, 5, 5], "polygon": [[0, 0], [1, 0], [0, 1]]}, "layers[0].mask", "exactly one"),
    ("layers/0/mask", {"threshold": 300}, "layers[0].mask.threshold", "<= 256"),
    ("layers/0/mask", {"threshold": 128, "invert": "yes"}, "layers[0].mask.invert", "true or false"),
    ("layers/0/mask", {"polygon": [[0, 0], [10, 0]]}, "layers[0].mask.polygon", "at least 3"),
    ("layers/0/mask", {"polygon": [[0, 0], [10, 0], [20, 0]]}, "layers[0].mask.polygon", "no area"),
    ("layers/0/mask", {"rect": [0, 0, -5, 5]}, "layers[0].mask.rect", "positive"),
    ("layers/0/mask", {"file": "nomask.png"}, "layers[0].mask.file", "no such file"),
    ("layers/0/mask", {"rect": [0, 0, 5, 5]}, "layers[0].mask", "selects no pixels"),
    ("links", [{"layers": ["bar", "ghost"], "segments": [[[20, 20], [30, 20]]]}], "links[0].layers[1]", "no layer"),
    ("links", [{"layers": ["bar", "bar"], "segments": [[[20, 20], [30, 20]]]}], "links[0].layers", "two different"),
    ("links", [{"layers": ["bar", "bar2"], "segments": [[[20, 20], [20, 20]]]}], "links[0].segments[0]", "zero length"),
    ("links", [{"layers": ["bar", "bar2"], "segments": [[[20, 2], [40, 3]]]}], "links[0].segments[0]",
     "no part of the segment lies inside both"),
    ("links", [{"layers": ["bar", "bar2"], "points": [[20, 3]]}], "links[0].points[0]", "not inside both"),
    ("links", [{"layers": ["bar", "bar2"], "segments": [[[20, 20], [30, 20]]], "strength": 2}],
     "links[0].strength", "<= 1"),
    ("pins/1/kind", "starch", "poses.bend.right", "is a starch pin"),
    ("pins/0/radius", 5, "pins[0].radius", "only a starch pin"),
    ("deformer", {"mode": "similar", "method": "igarashi"}, "deformer.mode", "needs method"),
    ("links", [{"layers": ["bar", "bar2"]}], "links[0].segments", "required"),
    ("pins/0/layer", "ghost", "pins[0].layer", "no layer"),
    ("pins/1/name", "left", "pins[1].name", "duplicate"),
    ("pins/0/at", [5, 5], "pins[0].at", "outside the mask"),
    ("pins/0/at", DELETE, "pins[0].at", "required"),
    ("pins/0/kind", "inside", "pins[0].kind", "not one of"),
    ("pins/0/depth", "deep", "pins[0].depth", "number"),
    ("bones", [["left", "elbow"]], "bones[0][1]", "no pin"),
    ("bones", [["left", "left"]], "bones[0]", "two different"),
    ("deformer", {"method": "magic"}, "deformer.method", "not one of"),
    ("deformer", {"weights": "cot"}, "deformer.weights", "not one of"),
    ("deformer", {"init": "zero"}, "deformer.init", "not one of"),
    ("deformer", {"iterations": -1}, "deformer.iterations", ">= 0"),
    ("deformer", {"iterations": 2.5}, "deformer.iterations", "whole number"),
    ("deformer", {"alpha": 0}, "deformer.alpha", "> 0"),
    ("deformer", {"relax_foldovers": 1}, "deformer.relax_foldovers", "true or false"),
    ("poses/rest", {"left": [1, 1]}, "poses.rest", "reserved"),
    ("poses/bend", {"elbow": [1, 1]}, "poses.bend.elbow", "no pin"),
    ("poses/bend", {"right": [1]}, "poses.bend.right", "2 items"),
    ("poses/bend", {"right": {"to": [1, 2], "angle": "x"}}, "poses.bend.right.angle", "number"),
    ("poses/bend", {"right": {"to": [1, 2], "spin": 3}}, "poses.bend.right.spin", "unknown key"),
    ("animation/fps", 0, "animation.fps", "> 0"),
    ("animation/keys", [], "animation.keys", "at least 1"),
    ("animation/keys/1/pose", "jump", "animation.keys[1].pose", "no pose"),
    ("animation/keys/1/ease", "bouncy", "animation.keys[1].ease", "not one of"),
    ("animation/keys/1/time", -1, "animation.keys[1].time", ">= 0"),
    ("animation/keys", [{"time": 1, "pose": "rest"}, {"time": 0.5, "pose": "bend"}], "animation.keys[1].time", "sorted"),
]


def _scene_with(path_in_scene, value):
    s = bar_scene()
    s["layers"].append({"name": "bar2", "image": "bar.png"})
    if path_in_scene.startswith("poses/rest"):
        s["poses"]["rest"] = value
    else:
        set_in(s, path_in_scene, value)
    return s


#: the cases found once the images are read: ``puppet render`` has made its GL context by then
GL_CASES = {"background:no such file", "source:no such file", "layers[0].image:no such file",
            "layers[0].mask.file:no such file", "layers[0].mask:selects no pixels", "pins[0].at:outside the mask",
            "links[0].points[0]:not inside both", "links[0].segments[0]:no part of the segment lies inside both"}


@pytest.mark.parametrize("where,value,jpath,words",
                         [pytest.param(*c, marks=pytest.mark.gl if c[2] + ":" + c[3] in GL_CASES else ()) for c in SCENE_CASES],
                         ids=[c[2] + ":" + c[3] for c in SCENE_CASES])
def test_bad_scene_value(make_scene, tmp_path, capsys, where, value, jpath, words):
    scene = make_scene(_scene_with(where, value), {"bar.png": bar_image()})
    out = tmp_path / "out.png"
    rc, err = run_cli(capsys, ["render", scene, "-o", str(out)])
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("puppet: error: ")
    assert "scene.json" in lines[0]
    assert f": {jpath}:" in lines[0], lines[0]
    assert words in lines[0], lines[0]
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def _bad_image(tmp_path, kind):
    p = tmp_path / "bad.png"
    if kind == "corrupt":
        good = tmp_path / "good.png"
        from PIL import Image
        Image.fromarray(bar_image()).save(good)
        data = good.read_bytes()
        p.write_bytes(data[: len(data) // 2])
    elif kind == "text":
        p.write_text("this is not an image\n")
    elif kind == "empty":
        p.write_bytes(b"")
    elif kind == "bomb":
        _png_header_only(p, 9000, 9000)  # 81 megapixels
    elif kind == "wide":
        _png_header_only(p, 20000, 2)
    elif kind == "folder":
        p.mkdir()
    return p


@pytest.mark.gl  # found once the image is read: after ``puppet render`` made its GL context
@pytest.mark.parametrize("kind,words", [("corrupt", "corrupt"), ("text", "not an image"), ("empty", "not an image"),
                                        ("bomb", "too large"), ("wide", "too large"), ("folder", "folder")])
def test_bad_layer_image(make_scene, tmp_path, capsys, kind, words):
    _bad_image(tmp_path, kind)
    s = bar_scene()
    s["layers"][0]["image"] = "bad.png"
    scene = make_scene(s)
    out = tmp_path / "out.png"
    rc, err = run_cli(capsys, ["render", scene, "-o", str(out)])
    assert rc == 2
    line, = err.strip().splitlines()
    assert "scene.json: layers[0].image:" in line and "bad.png" in line and words in line, line
    assert not out.exists()


def test_check_reads_the_background_image(make_scene, capsys):
    s = bar_scene()
    s["background"] = "nowhere.png"
    rc, err = run_cli(capsys, ["check", make_scene(s, {"bar.png": bar_image()})])
    assert rc == 2 and "scene.json: background: image" in err and "no such file" in err


def test_mask_file_of_wrong_size(make_scene, tmp_path, capsys):
    s = bar_scene()
    s["layers"][0]["mask"] = {"file": "m.png"}
    scene = make_scene(s, {"bar.png": bar_image(), "m.png": np.full((10, 10, 4), 255, np.uint8)})
    rc, err = run_cli(capsys, ["check", scene])
    assert rc == 2 and "layers[0].mask.file" in err and "10x10" in err


@pytest.mark.parametrize("text,words", [("{", "invalid JSON at line 1"), ("[1, 2]", "expected an object"),
                                        ('{"puppet": NaN, "layers": []}', "NaN"),
                                        (b"\xff\xfe\x00junk", "UTF-8")])
def test_unreadable_scene(tmp_path, capsys, text, words):
    p = tmp_path / "scene.json"
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    rc, err = run_cli(capsys, ["check", str(p)])
    assert rc == 2
    line, = err.strip().splitlines()
    assert "scene.json" in line and words in line, line


@pytest.mark.parametrize("fmt,name,kind", [("PNG", "picture.png", "a PNG image"), ("JPEG", "photo.jpg", "a JPEG image"),
                                             ("GIF", "anim.gif", "a GIF image"), ("WEBP", "p.webp", "a WebP image"),
                                             ("BMP", "p.bmp", "a BMP image"), ("TIFF", "p.tif", "a TIFF image"),
                                             ("PSD", "art.psd", "a Photoshop document"),
                                             ("ORA", "art.ora", "an OpenRaster document")])
@pytest.mark.parametrize("command", ["render", "check"])
def test_a_picture_given_as_the_scene_is_named_with_the_command_that_makes_one(tmp_path, capsys, fmt, name, kind,
                                                                                command):
    """``puppet render picture.png``: one line naming the file as a picture and pointing at
    ``puppet init`` (before: "not a text (UTF-8) file", "invalid JSON at line 1 column 1" for
    a GIF, "too large for a scene file" for a big PSD)."""
    from PIL import Image

    p = tmp_path / name
    if fmt == "PSD":  # a real one: from the bundled art if present, else the signature suffices
        p.write_bytes(b"8BPS\x00\x01" + bytes(20))
    elif fmt == "ORA":
        import zipfile

        with zipfile.ZipFile(p, "w") as z:
            z.writestr("mimetype", "image/openraster")
    else:
        Image.new("RGB", (8, 8), (200, 40, 40)).save(p, fmt)
    out = tmp_path / "out.png"
    rc, err = run_cli(capsys, [command, str(p)] + (["-o", str(out)] if command == "render" else []))
    assert rc == 2 and not out.exists()
    line, = err.strip().splitlines()
    assert name in line and f"is {kind}, not a scene file" in line and f"puppet init {p}" in line, line


def test_a_json_scene_is_not_taken_for_a_picture(tmp_path):
    from puppet.scene.format.reader import picture_kind

    for text in ("{}", "[]", "  {", "BM"[:1] + "{"):
        (tmp_path / "s.json").write_text(text)
        assert picture_kind(str(tmp_path / "s.json")) is None
    assert picture_kind(str(tmp_path)) is None and picture_kind(str(tmp_path / "missing")) is None


def test_missing_scene(tmp_path, capsys):
    rc, err = run_cli(capsys, ["check", str(tmp_path / "nope.json")])
    assert rc == 2 and "nope.json" in err and "no such scene file" in err


@pytest.mark.parametrize("args,words", [
    pytest.param(["--pose", "jump"], "no pose named 'jump'", marks=pytest.mark.gl),  # after the GL context
    (["--pose", "bend", "--time", "0.5"], "not allowed with"),
    (["--time", "-1"], "time must be"),
    (["--time", "abc"], "not a number"),
    (["--size", "100"], "expected WxH"),
    (["--size", "0x10"], "1..16384"),
])
def test_bad_render_flags(bar, tmp_path, capsys, args, words):
    out = tmp_path / "out.png"
    rc, err = run_cli(capsys, ["render", bar, "-o", str(out)] + args)
    assert rc == 2
    line, = err.strip().splitlines()
    assert line.startswith("puppet: error: ") and words in line, line
    assert not out.exists()


@pytest.mark.parametrize("out,words", [("out.jpg", "must end in .png"), ("no/such/dir/out.png", "does not exist")])
def test_bad_output_path(bar, tmp_path, capsys, out, words):
    rc, err = run_cli(capsys, ["render", bar, "-o", str(tmp_path / out)])
    assert rc == 2 and words in err


def test_time_without_animation(make_scene, tmp_path, capsys):
    s = bar_scene()
    del s["animation"]
    scene = make_scene(s, {"bar.png": bar_image()})
    rc, err = run_cli(capsys, ["mesh", scene, "--time", "0.5", "-o", str(tmp_path / "m.json")])
    assert rc == 2 and "no animation" in err and not (tmp_path / "m.json").exists()


def test_usage_errors_are_one_line(capsys):
    for args in (["frobnicate"], ["render"], []):
        rc, err = run_cli(capsys, args)
        assert rc == 2
        line, = err.strip().splitlines()
        assert line.startswith("puppet: error: ")


def test_console_script_has_no_traceback(tmp_path):
    """Through the real entry point in a fresh process, as a user runs it."""
    p = tmp_path / "scene.json"
    p.write_text(json.dumps({"puppet": 1, "layers": [{"name": "a", "image": "gone.png"}]}))
    r = subprocess.run([sys.executable, "-m", "puppet", "render", str(p), "-o", str(tmp_path / "o.png")],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip() == f"puppet: error: {p}: layers[0].image: image '{tmp_path / 'gone.png'}': no such file"
    assert "Traceback" not in r.stderr and not (tmp_path / "o.png").exists()
