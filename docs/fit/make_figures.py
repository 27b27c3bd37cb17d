"""Make the pictures of docs/algorithms.md §15 (issue 22), headless.

Run from the repository root:  .venv/bin/python docs/fit/make_figures.py
It writes the scenes it renders into a temporary folder, renders them with
`puppet render --wireframe` (EGL, no display needed) and puts the frames side by side:

* docs/fit/hinge-vs-segment.png: an arm linked to a body by a segment (left) and by a
  hinge point (right), its tip pin turned 90 degrees about the shoulder;
* docs/fit/garment-modes.png: the bundled dress garment narrowed to 75 % around its
  pins, in each mode (rest, rigid, similar, distort);
* docs/fit/garment-on-mannequin.png: the bundled t-shirt fitted onto a drawn mannequin
  narrower than it (its eight pins moved onto shoulders, arms, chest and hips), per mode.
"""
from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image, ImageDraw

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "docs", "fit")
PUPPET = os.path.join(os.path.dirname(sys.executable), "puppet")


def render(scene: dict, folder: str, name: str, pose: str | None) -> Image.Image:
    path = os.path.join(folder, name + ".json")
    with open(path, "w") as f:
        json.dump(scene, f)
    png = os.path.join(folder, f"{name}-{pose or 'rest'}.png")
    cmd = [PUPPET, "render", path, "-o", png, "--wireframe"] + (["--pose", pose] if pose else [])
    subprocess.run(cmd, check=True)
    return Image.open(png).convert("RGB")


def row(frames: list[tuple[str, Image.Image]], scale: float = 1.0) -> Image.Image:
    w, h = frames[0][1].size
    w2, h2 = int(w * scale), int(h * scale)
    out = Image.new("RGB", (w2 * len(frames), h2 + 24), "white")
    d = ImageDraw.Draw(out)
    for i, (label, im) in enumerate(frames):
        out.paste(im.resize((w2, h2), Image.LANCZOS), (i * w2, 24))
        d.text((i * w2 + 8, 6), label, fill=(0, 0, 0))
    return out


def arm_figure(folder: str) -> None:
    W, H = 360, 260
    body = np.zeros((H, W, 4), np.uint8)
    body[100:220, 20:220] = (90, 140, 200, 255)
    arm = np.zeros((H, W, 4), np.uint8)
    arm[110:140, 180:320] = (220, 160, 60, 255)
    Image.fromarray(body).save(os.path.join(folder, "body.png"))
    Image.fromarray(arm).save(os.path.join(folder, "arm.png"))
    base = {"puppet": 1, "canvas": [W, H], "background": [255, 255, 255, 255],
            "layers": [{"name": "body", "image": "body.png"}, {"name": "arm", "image": "arm.png"}],
            "pins": [{"name": "hip", "layer": "body", "at": [60, 190]},
                     {"name": "chest", "layer": "body", "at": [120, 130]},
                     {"name": "tip", "layer": "arm", "at": [310, 125]}],
            "poses": {"up": {"tip": [200, 15]}}}
    seg = dict(base, links=[{"layers": ["body", "arm"], "segments": [[[185, 125], [215, 125]]]}])
    hinge = dict(base, links=[{"layers": ["body", "arm"], "points": [[200, 125]]}])
    frames = [("rest", render(seg, folder, "arm-segment", None)),
              ("segment link", render(seg, folder, "arm-segment", "up")),
              ("hinge point", render(hinge, folder, "arm-hinge", "up"))]
    row(frames).save(os.path.join(OUT, "hinge-vs-segment.png"))


def garment_figure(folder: str) -> None:
    src = os.path.join(ROOT, "assets", "scenes", "dress-garment.json")
    raw = json.load(open(src))
    raw["source"] = os.path.abspath(os.path.join(ROOT, "assets", "scenes", raw["source"]))
    raw.pop("animation", None)
    pins = [p for p in raw["pins"] if p.get("kind", "interior") == "interior"]
    c = np.mean([p["at"] for p in pins], axis=0)
    raw["poses"] = {"narrow": {p["name"]: (c + 0.75 * (np.array(p["at"]) - c)).tolist() for p in pins}}
    frames = []
    for mode in ("rigid", "similar", "distort"):
        s = copy.deepcopy(raw)
        s["deformer"] = {"mode": mode}
        if not frames:
            frames.append(("rest", render(s, folder, "dress-rest", None)))
        frames.append((mode, render(s, folder, f"dress-{mode}", "narrow")))
    row(frames, scale=0.5).save(os.path.join(OUT, "garment-modes.png"))


def mannequin(path: str) -> None:
    """A plain mannequin (torso, neck, arms held out and down), narrower than the shirt."""
    im = Image.new("RGBA", (512, 512), (250, 246, 238, 255))
    d = ImageDraw.Draw(im)
    skin = (214, 196, 178, 255)
    d.polygon([(196, 120), (316, 120), (330, 250), (312, 420), (200, 420), (182, 250)], fill=skin)  # torso
    d.rectangle([236, 70, 276, 125], fill=skin)  # neck
    d.ellipse([226, 20, 286, 82], fill=skin)  # head
    d.polygon([(196, 122), (170, 130), (96, 240), (118, 252), (190, 170)], fill=skin)  # arms
    d.polygon([(316, 122), (342, 130), (416, 240), (394, 252), (322, 170)], fill=skin)
    im.save(path)


def mannequin_figure(folder: str) -> None:
    src = os.path.join(ROOT, "assets", "scenes", "tshirt-garment.json")
    raw = json.load(open(src))
    raw["layers"][0]["image"] = os.path.abspath(os.path.join(ROOT, "assets", "scenes", raw["layers"][0]["image"]))
    raw.pop("animation", None)
    mannequin(os.path.join(folder, "mannequin.png"))
    raw["background"] = "mannequin.png"
    # the shirt's pins onto the mannequin: shoulders, sleeves down the arms, chest, hips
    raw["poses"] = {"fit": {"shoulder_l": [200, 126], "shoulder_r": [312, 126], "sleeve_l": [126, 214],
                            "sleeve_r": [386, 214], "chest": [256, 215], "hem_l": [208, 390],
                            "hem_c": [256, 396], "hem_r": [304, 390]}}
    frames = []
    for mode in ("rigid", "similar", "distort"):
        s = copy.deepcopy(raw)
        s["deformer"] = {"mode": mode}
        if not frames:
            frames.append(("the shirt at rest over the mannequin", render(s, folder, "shirt-rest", None)))
        frames.append((f"fitted: {mode}", render(s, folder, f"shirt-{mode}", "fit")))
    row(frames, scale=0.5).save(os.path.join(OUT, "garment-on-mannequin.png"))


def main():
    with tempfile.TemporaryDirectory() as folder:
        arm_figure(folder)
        garment_figure(folder)
        mannequin_figure(folder)
    print("wrote hinge-vs-segment.png, garment-modes.png, garment-on-mannequin.png in", OUT)


if __name__ == "__main__":
    main()
