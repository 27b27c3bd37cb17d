"""Makes docs/import/import.png: the test character's PSD (tests/artfiles.py) as its
layers, the scene ``puppet init --pins auto --links auto`` makes of it (meshes, link
segments, pins), and the rig kept through ``--update`` after the arm was recoloured.

    .venv/bin/python docs/import/make_figure.py
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image, ImageDraw

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)

from tests import artfiles  # noqa: E402


def puppet(*args):
    subprocess.run([sys.executable, "-m", "puppet", *args], check=True, cwd=ROOT, capture_output=True)


def panel(rgba, title):
    bg = Image.new("RGBA", (rgba.shape[1], rgba.shape[0] + 28), (255, 255, 255, 255))
    im = Image.fromarray(rgba)
    bg.paste(im, (0, 28), im)
    ImageDraw.Draw(bg).text((8, 8), title, fill=(0, 0, 0, 255))
    return bg


def main():
    with tempfile.TemporaryDirectory() as tmp:
        art, scene = os.path.join(tmp, "gbot.psd"), os.path.join(tmp, "gbot.json")
        artfiles.write_psd(art)
        puppet("init", art, "-o", scene, "--pins", "auto", "--links", "auto")
        doc = json.load(open(scene))
        # 1: the layers, each box and name over the file's composite
        comp = artfiles.composite([(a, o) for _, _, a, o in artfiles.parts()])
        sketch = artfiles.sketch()
        base = Image.fromarray(comp)
        layers = Image.new("RGBA", base.size, (255, 255, 255, 255))
        faint = sketch.copy()
        faint[..., 3] //= 5
        layers.alpha_composite(Image.fromarray(faint))
        layers.alpha_composite(base)
        d = ImageDraw.Draw(layers)
        for L in doc["layers"]:
            w, h = Image.open(os.path.join(tmp, L["image"])).size
            x, y = L["offset"]
            d.rectangle([x, y, x + w - 1, y + h - 1], outline=(220, 30, 30, 255))
            d.text((x + 3, y + 2), L["name"], fill=(160, 0, 0, 255))
        # 2: meshes, links, pins
        wire = os.path.join(tmp, "wire.png")
        puppet("render", scene, "--wireframe", "-o", wire)
        mesh = Image.open(wire).convert("RGBA")
        d = ImageDraw.Draw(mesh)
        for link in doc["links"]:
            for (x0, y0), (x1, y1) in link["segments"]:
                d.line([x0, y0, x1, y1], fill=(0, 200, 0, 255), width=5)
        for p in doc["pins"]:
            x, y = p["at"]
            d.ellipse([x - 3, y - 3, x + 3, y + 3], fill=(255, 210, 0, 255), outline=(0, 0, 0, 255))
        # 3: a pose; 4: the same pose after the arm was recoloured and --update
        hand = max((p for p in doc["pins"] if p["layer"] == "arm_front"), key=lambda p: p["at"][0])
        foot = max((p for p in doc["pins"] if p["layer"] == "legs/left"), key=lambda p: p["at"][1])
        doc["poses"] = {"wave": {hand["name"]: [hand["at"][0] - 40, hand["at"][1] - 150],
                                 foot["name"]: [foot["at"][0] - 50, foot["at"][1] - 20]}}
        open(scene, "w").write(json.dumps(doc))
        posed, updated = os.path.join(tmp, "posed.png"), os.path.join(tmp, "updated.png")
        puppet("render", scene, "--pose", "wave", "-o", posed)
        artfiles.write_psd(art, recolour="arm_front")
        puppet("init", art, "-o", scene, "--update")
        puppet("render", scene, "--pose", "wave", "-o", updated)
        panels = [panel(np.asarray(layers), "gbot.psd: 7 visible layers (+ hidden sketch)"),
                  panel(np.asarray(mesh), "puppet init --pins auto --links auto"),
                  panel(np.asarray(Image.open(posed).convert("RGBA")), "posed ('wave')"),
                  panel(np.asarray(Image.open(updated).convert("RGBA")), "arm recoloured, --update: same pose")]
        W = sum(p.width for p in panels) + 10 * (len(panels) - 1)
        out = Image.new("RGBA", (W, panels[0].height), (255, 255, 255, 255))
        x = 0
        for p in panels:
            out.paste(p, (x, 0))
            x += p.width + 10
        out = out.resize((out.width * 2 // 3, out.height * 2 // 3), Image.LANCZOS)
        out.convert("RGB").save(os.path.join(ROOT, "docs", "import", "import.png"), optimize=True)


if __name__ == "__main__":
    main()
