"""``puppet dressroom``: the scene's ``garment`` section, the per-pixel depth, the
garments rendered as ``puppet render`` draws them, draw order, and the refusals."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import cv2
import numpy as np
import pytest
from PIL import Image

from puppet.cli import main
from puppet.errors import SceneError
from puppet.room.depth import LOW, STEPS, depth_rgba
from puppet.room.page import thumbnail
from puppet.scene.format.load import load_scene_data
from tests.room.art import GARMENTS, SKIN, garment, room_files
from tests.room.reference import front_depth, layer_depth, triangle_ids


def test_garment_section_is_read_with_its_defaults_and_checked(tmp_path):
    path = garment(str(tmp_path), "hat")
    assert load_scene_data(path).garment == {"name": "cap", "category": "accessory", "order": 0}
    assert load_scene_data(garment(str(tmp_path), "shirt", section={})).garment is None
    assert load_scene_data(garment(str(tmp_path), "shirt", section={"order": -2.5})).garment == \
        {"category": "top", "order": -2.5}
    for bad, where in (({"category": "hats"}, "garment.category"), ({"order": "first"}, "garment.order"),
                       ({"name": ""}, "garment.name"), ({"colour": 1}, "garment.colour")):
        with pytest.raises(SceneError) as e:
            load_scene_data(garment(str(tmp_path), "shirt", section=bad))
        assert e.value.path == where and e.value.file.endswith("shirt.json")
        assert "\n" not in str(e.value)


def test_layer_depth_interpolates_at_pixel_centres_where_the_texture_shows():
    # a 4x2 square of two triangles, depth 0 on the left edge and 4 on the right
    V = np.array([[1.0, 1.0], [5.0, 1.0], [5.0, 3.0], [1.0, 3.0]])
    F = np.array([[0, 1, 2], [0, 2, 3]])
    image = np.zeros((2, 4, 4), np.uint8)
    image[:, :3, 3] = 255  # the texture's right column is clear
    d = layer_depth(V, V, F, np.array([0.0, 4.0, 4.0, 0.0]), image, (1, 1), (7, 4))
    shows = ~np.isnan(d)
    # the clear column and beyond: NaN; the pixels whose centres are inside, no others
    assert shows[1:3, 1:4].all() and not shows[:, 4:].any() and not shows[0].any() and not shows[:, 0].any()
    assert not shows[3].any()
    assert np.allclose(d[1:3, 1:4], [[0.5, 1.5, 2.5]] * 2)  # pixel centres x + 0.5, depth x - 1
    # posed: the same rest mesh moved 2 px right keeps its depths on the moved pixels
    moved = layer_depth(V + (2, 0), V, F, np.array([0.0, 4.0, 4.0, 0.0]), image, (1, 1), (7, 4))
    assert np.allclose(moved[1:3, 3:6], d[1:3, 1:4])
    front = front_depth([d, np.where(np.isnan(d), np.nan, 1.0)], [0, 0])
    assert np.allclose(front[1:3, 1:4], [[1.0, 1.5, 2.5]] * 2)
    # ranks: the second layer (rank 3, pin depth 1) is in front everywhere, its pin depth kept
    assert np.array_equal(front_depth([d, np.where(np.isnan(d), np.nan, 1.0)], [0, 3])[1:3, 1:4], np.ones((2, 3)))
    assert np.isnan(front[0, 6]) and front[0, 0] == 1.0  # grown one pixel round what shows, no further


def test_depth_image_codes_read_back():
    d = np.array([[LOW, 0.0, 1.0 / STEPS], [-3.25, 127.99, np.nan]])
    im = depth_rgba(d).astype(np.int64)
    code = im[..., 0] * 256 + im[..., 1]
    back = np.where(im[..., 2] == 255, code / STEPS + LOW, np.nan)
    assert np.abs(back - d)[~np.isnan(d)].max() <= 0.5 / STEPS and np.isnan(back[1, 2])  # within half a step
    assert (im[..., 3] == 255).all()


def test_the_command_line_loads_no_room_module():
    code = "import sys, puppet.cli; print(sorted(m for m in sys.modules if m.startswith('puppet.room.')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["['puppet.room.command']"]


def refused(argv, capsys, out) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert not os.path.exists(out)
    return err


def test_refusals_name_the_file_and_value(tmp_path, capsys):
    folder = str(tmp_path)
    body, _ = room_files(folder, ())
    out = os.path.join(folder, "room.html")
    wide = garment(folder, "shirt", canvas=(60, 80))
    err = refused(["dressroom", body, wide, "-o", out], capsys, out)
    assert "shirt.json" in err and "60x80" in err and "64x80" in err
    odd = garment(folder, "jeans", section={"category": "hats"})
    err = refused(["dressroom", body, odd, "-o", out], capsys, out)
    assert "jeans.json" in err and "garment.category" in err and "'hats'" in err
    err = refused(["dressroom", body, garment(folder, "vest"), "-o", os.path.join(folder, "room.png")], capsys,
                  os.path.join(folder, "room.png"))
    assert "room.png" in err and "ROOM.html" in err


@pytest.mark.gl
def test_duplicate_names_are_refused(tmp_path, capsys):
    folder = str(tmp_path)
    body, _ = room_files(folder, ())
    out = os.path.join(folder, "room.html")
    a = garment(folder, "shirt", section={"name": "cap"})
    err = refused(["dressroom", body, a, garment(folder, "hat"), "-o", out], capsys, out)
    assert "hat.json" in err and "'cap'" in err and "shirt.json" in err


@pytest.mark.gl
def test_garments_are_puppet_render_of_their_fit_pose_in_draw_order(tmp_path):
    from puppet.room.model import load_garment, load_room, wear

    folder = str(tmp_path)
    body, files = room_files(folder, ("hat", "vest", "jeans", "shirt"))
    room = load_room(body, files)
    assert [g.name for g in room.garments] == ["jeans", "shirt", "vest", "cap"]  # bottom, top (order 0, 1), accessory
    for g, pose in zip(room.garments, ("rest", "fit", "rest", "rest")):
        ref = os.path.join(folder, g.name + "-ref.png")
        assert main(["render", g.file, *(["--pose", pose] if pose != "rest" else []), "-o", ref]) == 0
        drawn = g.on_canvas(room.canvas)
        assert np.array_equal(drawn, np.asarray(Image.open(ref).convert("RGBA"))), g.name
        # cropped to where it shows
        assert (g.rgba[0, :, 3] > 0).any() and (g.rgba[-1, :, 3] > 0).any() and (g.rgba[:, 0, 3] > 0).any()
        assert (g.rgba[:, -1, 3] > 0).any() and g.depth.shape == g.rgba.shape[:2]
        shows, depth = drawn[..., 3] > 0, g.depth_on_canvas(room.canvas)
        assert not np.isnan(depth[shows]).any()  # a depth wherever the garment shows
        near = cv2.dilate(shows.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        assert not (~np.isnan(depth) & ~near).any()  # and one pixel round it at most
    jeans, shirt = room.garments[:2]
    assert np.allclose(jeans.depth[~np.isnan(jeans.depth)], 1.0)  # its one pin's depth, everywhere
    assert np.allclose(shirt.depth[~np.isnan(shirt.depth)], 0.0)
    # the fit pose moved the shirt's hem: its render at rest differs
    rest = os.path.join(folder, "rest.png")
    assert main(["render", shirt.file, "-o", rest]) == 0
    assert not np.array_equal(shirt.on_canvas(room.canvas), np.asarray(Image.open(rest).convert("RGBA")))
    # wearing: hand-checked pixels (cloth colours are opaque inside their 2-pixel margins)
    on = wear(room, {"shirt", "jeans", "cap"})
    assert tuple(on[5, 32, :3]) == GARMENTS["hat"][0]
    assert tuple(on[45, 32, :3]) == GARMENTS["shirt"][0]  # the top over the bottom
    assert tuple(on[70, 32, :3]) == GARMENTS["jeans"][0]
    assert tuple(on[60, 24, :3]) == GARMENTS["jeans"][0] and tuple(wear(room, set())[60, 24, :3]) == SKIN
    # a garment scene's own background is left out: it would cover the mannequin
    with open(jeans.file) as f:
        doc = json.load(f)
    doc["background"] = [9, 9, 9, 255]
    with open(jeans.file, "w") as f:
        json.dump(doc, f)
    again = load_garment(jeans.file, room.canvas, body)
    assert np.array_equal(again.rgba, jeans.rgba) and again.at == jeans.at
    assert again.on_canvas(room.canvas)[0, 0, 3] == 0


@pytest.mark.gl
def test_folder_form_holds_the_page_and_the_pictures(tmp_path, capsys):
    folder = str(tmp_path)
    body, files = room_files(folder, ("shirt", "jeans", "hat"))
    out = os.path.join(folder, "room") + "/"
    assert main(["dressroom", body, *files, "-o", out]) == 0
    pictures = sorted(os.listdir(os.path.join(out, "pictures")))
    assert sorted(os.listdir(out)) == ["index.html", "pictures"]
    assert pictures == ["0001-depth.png", "0001.png", "0002-depth.png", "0002.png", "0003-depth.png", "0003.png",
                        "mannequin.png", "thumbs-001.png"]
    text = open(os.path.join(out, "index.html"), encoding="utf-8").read()
    assert "data:image" not in text and '"pictures/0002-depth.png"' in text
    # the thumbnails on one sheet, each in its cell: the garment's crop scaled to 144 px its longer side
    sheet = np.asarray(Image.open(os.path.join(out, "pictures", "thumbs-001.png")))
    assert sheet.shape == (144, 3 * 144, 4)
    meta = json.loads(re.search(r'<script id="room-meta" type="application/json">(.*?)</script>', text, re.S).group(1))
    for k, g in enumerate(meta["garments"]):
        t = g["thumb"]
        crop = np.asarray(Image.open(os.path.join(out, g["image"])))
        w, h = t["size"]
        assert t["sheet"] == "pictures/thumbs-001.png" and t["at"] == [144 * k, 0] and max(w, h) == 144
        assert abs(w / h - crop.shape[1] / crop.shape[0]) < 0.05
        assert np.array_equal(sheet[:h, 144 * k:144 * k + w], thumbnail(crop))
    # the pictures are the single file's: the mannequin as it is, garment 1 (jeans, a bottom) cropped
    assert np.array_equal(np.asarray(Image.open(os.path.join(out, "pictures", "mannequin.png"))),
                          np.asarray(Image.open(body).convert("RGBA")))
    jeans = np.asarray(Image.open(os.path.join(out, "pictures", "0001.png")))
    assert jeans.shape == (30, 20, 4) and tuple(jeans[5, 5]) == GARMENTS["jeans"][0] + (255,)
    # a folder that holds other files is never emptied: refused
    err = refused(["dressroom", body, *files, "-o", out], capsys, os.path.join(out, "nothing"))
    assert "index.html" in err and "room" in err


@pytest.mark.gl
def test_the_bundled_room_dresses_and_tucks_in():  # about 1 s
    """assets/scenes/room (docs/dressroom.md): every garment on the mannequin's canvas, in
    draw order; the t-shirt's fit pose carries its hem's depth below the jeans'."""
    from puppet.room.model import load_room

    folder = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                          "assets", "scenes", "room")
    names = ("shoes", "dress", "t-shirt", "jeans")
    room = load_room(os.path.join(folder, "mannequin.json"), [os.path.join(folder, n + ".json") for n in names])
    assert room.canvas == (700, 720) and room.mannequin[0, 0].tolist() == [84, 150, 200, 255]
    assert [g.name for g in room.garments] == ["jeans", "t-shirt", "dress", "shoes"]
    jeans, shirt = room.garments[:2]
    assert np.nanmax(np.abs(jeans.depth)) == 0  # no pin depth
    shirt_depth, jeans_depth = shirt.depth_on_canvas(room.canvas), jeans.depth_on_canvas(room.canvas)
    hem, chest = shirt_depth[445, 350], shirt_depth[300, 350]
    assert -1 <= hem < -0.5 and abs(chest) < 0.3, (hem, chest)
    both = (shirt.on_canvas(room.canvas)[..., 3] > 0) & (jeans.on_canvas(room.canvas)[..., 3] > 0)
    assert both.sum() > 1000 and (shirt_depth[both] < jeans_depth[both]).mean() > 0.95  # a tucked hem goes under


def test_triangle_ids_hold_the_pixel_centres_inside_the_later_triangle():
    """The vectorised fill against a pixel-by-pixel test, on random overlapping (folded)
    triangles of both windings, some off the frame and one degenerate."""

    rng = np.random.default_rng(4)
    for _ in range(4):
        V = rng.uniform(-3.0, 23.0, (12, 2))
        F = rng.integers(0, 12, (10, 3))
        F[0] = [1, 1, 2]  # degenerate: holds nothing
        want = np.full((15, 20), -1)
        for y in range(15):
            for x in range(20):
                p = np.array([x + 0.5, y + 0.5])
                for t, (a, b, c) in enumerate(V[F]):
                    det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
                    if det == 0:
                        continue
                    l1 = ((p[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (p[1] - a[1])) / det
                    l2 = ((b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1])) / det
                    if l1 >= -1e-9 and l2 >= -1e-9 and l1 + l2 <= 1 + 1e-9:
                        want[y, x] = t
        got = triangle_ids(V, F, (20, 15))
        assert (got >= 0).sum() > 20 and np.array_equal(got, want)
