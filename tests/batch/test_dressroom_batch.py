"""``puppet batch --template ... --dressroom MANNEQUIN``: each matched picture becomes a
garment on the template's canvas and the batch writes ``OUT_DIR/room/``."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import zipfile

import cv2
import numpy as np
import pytest
from PIL import Image

from puppet.batch import command as C
from puppet.batch.template import cached
from puppet.batch.runner import run_batch
from puppet.cli import build_parser
from puppet.errors import SceneError
from puppet.room.model import load_garment
from tests.batch import garments as G
from tests.batch.conftest import temporaries
from tests.conftest import ROOT

ROOMS = os.path.join(ROOT, "assets", "scenes", "room")
TEMPLATE = os.path.join(ROOMS, "t-shirt.json")  # a room garment: canvas 700x720, pose fit, category top
SHIRT = os.path.join(ROOMS, "t-shirt.png")
CANVAS = (700, 720)


def mannequin(path, size=CANVAS) -> str:
    m = np.zeros((size[1], size[0], 4), np.uint8)
    m[..., :3], m[..., 3] = (84, 150, 200), 255
    m[150:700, 300:400, :3] = (230, 190, 160)
    Image.fromarray(m).save(path)
    return str(path)


def room_meta(folder) -> dict:
    text = open(os.path.join(folder, "index.html"), encoding="utf-8").read()
    return json.loads(re.search(r'<script id="room-meta" type="application/json">(.*?)</script>', text, re.S)[1])


def on_canvas(folder, entry) -> np.ndarray:
    """A garment of the room's page, as the page places it on the mannequin's canvas."""
    out = np.zeros((CANVAS[1], CANVAS[0], 4), np.uint8)
    (x, y), (w, h) = entry["at"], entry["size"]
    out[y:y + h, x:x + w] = np.asarray(Image.open(os.path.join(folder, entry["image"])).convert("RGBA"))
    return out


def room_depth(folder, entry) -> np.ndarray:
    """A garment's depth image of the room's page, decoded and placed on the canvas (NaN where none)."""
    from puppet.room.depth import LOW, STEPS

    out = np.full((CANVAS[1], CANVAS[0]), np.nan)
    (x, y), (w, h) = entry["at"], entry["size"]
    d = np.asarray(Image.open(os.path.join(folder, entry["depth"])).convert("RGBA")).astype(np.float64)
    out[y:y + h, x:x + w] = np.where(d[..., 2] > 0, (d[..., 0] * 256 + d[..., 1]) / STEPS + LOW, np.nan)
    return out


def grey_off(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of the canvas's pixels whose colour or alpha differ by more than 40 levels."""
    return float((np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 40).mean())


def iou(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a[..., 3] > 0, b[..., 3] > 0
    return float((a & b).sum() / (a | b).sum())


def batch(client, argv: list[str]) -> dict:
    """``puppet batch ARGV`` as the command runs it, on the shared test cluster."""
    args = build_parser().parse_args(["batch", *argv])
    out_dir = os.path.realpath(args.output)
    jobs = C._jobs(args, out_dir)
    os.makedirs(out_dir, exist_ok=True)
    return run_batch(jobs, out_dir, client=client, resume=args.resume, finale=C._finale(args, out_dir, print),
                     **C._reads(args))


@pytest.mark.gl
@pytest.mark.slow
def test_the_batch_writes_the_room_of_the_matched_garments(cluster2, tmp_path):
    imgs = tmp_path / "imgs"
    imgs.mkdir()
    sims = {"big": G.similar_copy(SHIRT, imgs / "big.png", scale=1.3, angle=20.0, shift=(120, 10), size=(600, 560)),
            "small": G.similar_copy(SHIRT, imgs / "small.png", scale=0.8, angle=-12.0, shift=(30, 60),
                                    size=(340, 330))}
    G.circle(imgs / "round.png")
    man = mannequin(tmp_path / "mannequin.png")
    out = tmp_path / "out"
    argv = ["--template", TEMPLATE, "--images", str(imgs), "--pose", "fit", "-o", str(out), "--dressroom", man]
    summary = batch(cluster2, argv)
    assert summary["counts"] == {"done": 2, "failed": 0, "no-match": 1, "skipped": 0, "not-run": 0}
    report = json.loads((out / "report.json").read_text())
    assert report["room"] == {"folder": "room/", "garments": ["big", "small"], "refused": []}
    assert {j["output"]: j.get("garment") for j in report["jobs"]} == {
        "big.png": "garments/big.json", "small.png": "garments/small.json", "round.png": "garments/round.json"}
    assert sorted(os.listdir(out / "garments")) == ["big.json", "big.png", "big.room.zip", "small.json", "small.png",
                                                    "small.room.zip"]
    meta = room_meta(out / "room")
    assert [g["name"] for g in meta["garments"]] == ["big", "small"] and meta["canvas"] == list(CANVAS)
    template = load_garment(TEMPLATE, CANVAS, man)  # the template's own fit, on the mannequin
    for entry in meta["garments"]:
        scene = json.loads((out / "garments" / f"{entry['name']}.json").read_text())
        assert scene["canvas"] == list(CANVAS) and scene["garment"] == {"name": entry["name"], "category": "top"}
        assert scene["layers"][0]["mask"] == "alpha" and set(scene["poses"]) == {"fit"}
        picture = imgs / f"{entry['name']}.png"
        r = cached(TEMPLATE).transfer(str(picture))  # what the job transferred: pins and targets mapped back
        assert abs(r.similarity.a - sims[entry["name"]][0]) < 0.01
        assert [p["name"] for p in scene["pins"]] == [p["name"] for p in r.scene["pins"]]
        assert np.allclose(r.similarity.apply([p["at"] for p in scene["pins"]]),
                           [p["at"] for p in r.scene["pins"]], atol=0.01)
        fit = {k: t["to"] if isinstance(t, dict) else t for k, t in scene["poses"]["fit"].items()}
        want = {k: t["to"] if isinstance(t, dict) else t for k, t in r.scene["poses"]["fit"].items()}
        assert np.allclose(r.similarity.apply([fit[k] for k in want]), list(want.values()), atol=0.01)
        drawn = on_canvas(out / "room", entry)
        # the room's pictures are those its job drew (from its own solve, moved by S^-1) ...
        with zipfile.ZipFile(out / "garments" / f"{entry['name']}.room.zip") as z:
            assert z.read("picture.png") == (out / "room" / entry["image"]).read_bytes()
            assert z.read("depth.png") == (out / "room" / entry["depth"]).read_bytes()
            assert json.loads(z.read("meta.json"))["at"] == entry["at"]
        # ... and show what `puppet dressroom` draws of the garment scene (the same picture; its
        # mesh made again on it): within a pixel at the outline, the same depths
        g = load_garment(str(out / "garments" / f"{entry['name']}.json"), CANVAS, man)
        ref = g.on_canvas(CANVAS)
        assert iou(drawn, ref) > 0.99 and grey_off(drawn, ref) < 0.003, entry["name"]
        ours = room_depth(out / "room", entry)
        theirs = g.depth_on_canvas(CANVAS)
        both = ~np.isnan(ours) & ~np.isnan(theirs)
        assert both.sum() > 0.95 * (~np.isnan(theirs)).sum() and np.abs(ours[both] - theirs[both]).max() < 0.05
        assert iou(drawn, template.on_canvas(CANVAS)) > 0.9, entry["name"]
    # the batch's own outputs are what template mode renders without --dressroom
    plain = tmp_path / "plain"
    batch(cluster2, argv[:6] + ["-o", str(plain)])
    for name in ("big.png", "small.png"):
        assert (plain / name).read_bytes() == (out / name).read_bytes()
    assert not (plain / "room").exists() and not (plain / "garments").exists()
    assert "room" not in json.loads((plain / "report.json").read_text())
    # --resume: every job up to date, the room written again from the garments on disk
    old = (out / "room" / "index.html").read_bytes()
    summary = batch(cluster2, argv + ["--resume"])
    assert summary["counts"]["skipped"] == 2 and summary["counts"]["done"] == 0
    assert (out / "room" / "index.html").read_bytes() == old
    assert temporaries(out) == []
    for gone in ("small.json", "big.room.zip"):  # a garment's file gone: its job is not up to date
        (out / "garments" / gone).unlink()
        summary = batch(cluster2, argv + ["--resume"])
        assert summary["counts"]["skipped"] == 1 and summary["counts"]["done"] == 1
        assert (out / "room" / "index.html").read_bytes() == old
    # a garment scene edited since its job drew it: the room draws the scene as it is now
    edited = json.loads((out / "garments" / "small.json").read_text())
    edited["garment"]["name"] = "small shirt"
    (out / "garments" / "small.json").write_text(json.dumps(edited))
    (out / "garments" / "big.room.zip").write_bytes(b"not a zip")  # and a spoiled one: the same
    summary = batch(cluster2, argv + ["--resume"])
    assert summary["counts"]["skipped"] == 2  # the jobs' inputs are unchanged
    meta = room_meta(out / "room")
    assert sorted(g["name"] for g in meta["garments"]) == ["big", "small shirt"]
    for entry, stem in zip(meta["garments"], ("big", "small")):
        assert np.array_equal(on_canvas(out / "room", entry),
                              load_garment(str(out / "garments" / f"{stem}.json"), CANVAS, man).on_canvas(CANVAS))
    # a room holding what the batch did not write is never replaced: refused before any job runs
    (out / "room" / "notes.txt").write_text("mine")
    before = (out / "report.json").read_bytes()
    with pytest.raises(SceneError, match=r"room: cannot write: the folder holds other files than what puppet "
                                         r"wrote there \(e.g. 'notes.txt'\)"):
        batch(cluster2, argv)
    assert (out / "room" / "notes.txt").read_text() == "mine" and (out / "report.json").read_bytes() == before


def test_dressroom_refusals(tmp_path):
    """Refused before any job runs; one CLI run for the exit status and that nothing is written."""
    imgs = tmp_path / "imgs"
    imgs.mkdir()
    G.similar_copy(SHIRT, imgs / "a.png", scale=1.0, angle=0.0, shift=(0, 0), size=(320, 300))
    out = tmp_path / "out"
    small = mannequin(tmp_path / "small.png", size=(600, 720))
    base = ["--template", TEMPLATE, "--images", imgs, "--pose", "fit", "-o", out]
    cases = [
        ([imgs, "-o", out, "--dressroom", small], "--dressroom is for template mode (with --template)"),
        (base + ["--dressroom", tmp_path / "none.png"], "none.png: --dressroom: no such file"),
        (base + ["--dressroom", SHIRT], "--dressroom: the mannequin is 307x"),
    ]
    for argv, want in cases:
        args = build_parser().parse_args(["batch", *map(str, argv)])
        with pytest.raises(SceneError) as e:
            C._jobs(args, str(out))
        assert want in str(e.value) and len(str(e.value).splitlines()) == 1
    clash = tmp_path / "clash"  # a garment the batch would write is one of its pictures
    (clash / "garments").mkdir(parents=True)
    G.similar_copy(SHIRT, clash / "garments" / "a.png", scale=1.0, angle=0.0, shift=(0, 0), size=(320, 300))
    args = build_parser().parse_args(["batch", "--template", TEMPLATE, "--images", str(clash / "garments"), "--pose",
                                      "fit", "-o", str(clash), "--dressroom", mannequin(tmp_path / "m.png")])
    with pytest.raises(SceneError, match="job 0: output 'garments/a.png' would replace"):
        run_batch(C._jobs(args, str(clash)), str(clash), client=object(), **C._reads(args))
    assert sorted(os.listdir(clash)) == ["garments"] and os.listdir(clash / "garments") == ["a.png"]
    r = subprocess.run([sys.executable, "-m", "puppet", "batch", *map(str, base + ["--dressroom", small])], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "the mannequin is 600x720, the template's canvas 700x720" \
        in lines[0], r.stderr
    assert not out.exists()


@pytest.mark.gl
def test_a_garment_the_room_refuses_is_left_out_and_said(tmp_path):
    from puppet.batch.dressroom import make_room
    from tests.room import art

    man, (shirt, jeans) = art.room_files(tmp_path, names=("shirt", "jeans"))
    twin = tmp_path / "twin.json"
    twin.write_text(json.dumps(dict(json.load(open(shirt)), garment={"name": "shirt"})))  # a second "shirt"
    said = []
    body = np.asarray(Image.open(man).convert("RGBA"))
    out = make_room(str(tmp_path), body, man, [shirt, str(twin), jeans, str(tmp_path / "gone.json")], inputs=[],
                    say=said.append)
    assert out["garments"] == ["jeans", "shirt"]  # in draw order: bottom, top
    assert [r["garment"] for r in out["refused"]] == [str(twin), str(tmp_path / "gone.json")]
    assert "garment name 'shirt' is also the name of" in out["refused"][0]["error"]
    assert len(said) == 2 and all(s.startswith("puppet batch: dressroom: left out: ") for s in said)
    assert [g["name"] for g in room_meta(tmp_path / "room")["garments"]] == ["jeans", "shirt"]


@pytest.mark.gl
def test_automatic_exterior_points_keep_their_targets_in_the_room_garment(tmp_path):
    """The room garment's automatic exterior points are made again on the resampled picture
    and numbered by its own outline: a pose target of the picture's LAYER:extI goes to the
    garment's point at the same place, wherever its number."""
    from puppet.batch import jobs as J
    from puppet.batch.work import run_job
    from puppet.imaging import masks as mk
    from puppet.imaging.io import load_rgba
    from puppet.scene.rig.exterior import auto_points

    doc = json.load(open(TEMPLATE))
    doc["layers"][0]["image"] = SHIRT
    doc["layers"][0]["exterior"] = {"auto": True, "beta": 1.0}
    tpl = cached(TEMPLATE)  # the template's own points, on the template's canvas
    ext = auto_points(tpl.image.mask, tpl.image.offset, 1.0)
    assert len(ext) >= 4
    for i, p in enumerate(ext):  # every point moved 12 px right
        doc["poses"]["fit"][f"shirt:ext{i}"] = [float(p[0]) + 12.0, float(p[1])]
    template = tmp_path / "tpl.json"
    template.write_text(json.dumps(doc))
    imgs = tmp_path / "imgs"
    imgs.mkdir()
    a = np.exp(1j * np.radians(45.0))  # turned 45 degrees about its centre in a 445 px picture
    b = complex(222.5, 222.5) - a * complex(153.5, 153.5)
    G.similar_copy(SHIRT, imgs / "turned.png", scale=1.0, angle=45.0, shift=(b.real, b.imag), size=(445, 445))
    out = str(tmp_path / "out")
    room = {"canvas": list(CANVAS), "category": "top"}
    job = J.template_jobs(str(template), str(imgs), "fit", out, {}, tolerance=None, room=room)[0]
    os.makedirs(out)
    rec = run_job(job)
    assert rec["status"] == "done", rec
    scene = json.loads(open(job["room"]["scene"]).read())
    named = [k for k in scene["poses"]["fit"] if k.startswith("shirt:ext")]
    picture = load_rgba(job["room"]["picture"])
    mine = auto_points(mk.alpha_mask(picture), tuple(scene["layers"][0]["offset"]), 1.0)
    assert len(named) >= 1
    for nm in named:
        j = int(nm[len("shirt:ext"):])
        assert np.linalg.norm(ext - mine[j], axis=1).min() < 4.0, (nm, mine[j])  # a template point's place
        to = np.asarray(scene["poses"]["fit"][nm], float)
        assert np.linalg.norm(to - mine[j] - (12.0, 0.0)) < 3.0, (nm, to, mine[j])  # moved as it is there
    # the picture numbers its points otherwise than the resampled garment: renamed
    picture_named = [k for k in cached(str(template)).transfer(str(imgs / "turned.png")).scene["poses"]["fit"]
                     if k.startswith("shirt:ext")]
    assert len(picture_named) == len(named) and picture_named != named


def test_a_big_picture_is_averaged_into_the_templates_pixels(tmp_path):
    """A picture 3 times the template's size (each template pixel a 3 x 3 block of it) is
    resampled, through its k x k block averages, back to the template's own pixels."""
    from puppet.batch.dressroom import resample
    from puppet.geom.outline_match import Similarity

    tpl = cached(TEMPLATE).image
    G.similar_copy(SHIRT, tmp_path / "big.png", scale=3.0, angle=0.0, shift=(30.0, 45.0), size=(1000, 1000),
                   nearest=True)
    from puppet.imaging.io import load_rgba

    big = load_rgba(str(tmp_path / "big.png"))
    ox, oy = tpl.offset  # template canvas p -> big picture 3 (p - offset) + shift
    S = Similarity(a=3.0 + 0j, b=complex(30.0 - 3 * ox, 45.0 - 3 * oy))
    crop, (x, y) = resample(big, big[..., 3] > 0, S, CANVAS)
    want = np.zeros((CANVAS[1], CANVAS[0], 4), np.uint8)
    h, w = tpl.rgba.shape[:2]
    want[int(oy):int(oy) + h, int(ox):int(ox) + w] = load_rgba(SHIRT)
    got = np.zeros_like(want)
    got[y:y + crop.shape[0], x:x + crop.shape[1]] = crop
    # the blocks start a pixel before the mask's box, not on the copy's 3 x 3 grid: each is
    # shifted back by the warp (bilinear), a third of a pixel of blur at the outline
    solid = lambda im: im[..., 3] > 127  # noqa: E731
    assert (solid(got) & solid(want)).sum() / (solid(got) | solid(want)).sum() > 0.99
    assert grey_off(got, want) < 0.01  # the outline only (a 1 px ring is 0.6 % of this canvas)
    inside = cv2.erode((want[..., 3] == 255).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert np.abs(got[inside].astype(int) - want[inside]).mean() < 2.0  # the block averages are its pixels
