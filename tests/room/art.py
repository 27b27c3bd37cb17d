"""Tiny dressing-room art for the tests: a 64x80 mannequin picture and garment scenes of
one rectangle layer each (a 2-pixel clear margin), on its canvas."""
from __future__ import annotations

import json
import os

import numpy as np
from PIL import Image

SIZE = (64, 80)
SKIN = (180, 150, 130)
#: name -> (colour, (x, y, w, h) of the layer image, garment section, pins, fit pose)
GARMENTS = {
    "shirt": ((200, 40, 40), (18, 20, 28, 30), {"category": "top"},
              [{"at": [24, 24]}, {"at": [40, 24]}, {"at": [32, 46]}], {"p2": [34, 47]}),
    "jeans": ((40, 60, 200), (20, 40, 24, 34), {"category": "bottom"}, [{"at": [32, 44], "depth": 1}], None),
    "hat": ((30, 160, 60), (24, 2, 16, 10), {"category": "accessory", "name": "cap"}, [], None),
    "vest": ((230, 200, 40), (20, 22, 24, 20), {"category": "top", "order": 1}, [], None),
}


def mannequin(folder) -> str:
    m = np.full((SIZE[1], SIZE[0], 4), 255, np.uint8)
    m[10:75, 22:42, :3] = SKIN
    path = os.path.join(folder, "mannequin.png")
    Image.fromarray(m).save(path)
    return path


def garment(folder, name: str, *, canvas=SIZE, section=None) -> str:
    """Write garment ``name`` of :data:`GARMENTS` as ``folder/NAME.json`` (``section``
    replaces its ``garment`` section; ``{}``: none)."""
    colour, (x, y, w, h), spec, pins, fit = GARMENTS[name]
    im = np.zeros((h, w, 4), np.uint8)
    im[2:-2, 2:-2] = colour + (255,)
    Image.fromarray(im).save(os.path.join(folder, name + ".png"))
    doc = {"puppet": 1, "canvas": list(canvas),
           "layers": [{"name": "cloth", "image": name + ".png", "offset": [x, y], "mask": "alpha"}],
           "pins": [{"name": f"p{i}", "layer": "cloth", **p} for i, p in enumerate(pins)]}
    if fit:
        doc["poses"] = {"fit": fit}
    spec = spec if section is None else section
    if spec:
        doc["garment"] = spec
    path = os.path.join(folder, name + ".json")
    with open(path, "w") as f:
        json.dump(doc, f)
    return path


def room_files(folder, names=("shirt", "jeans", "hat")) -> tuple[str, list[str]]:
    os.makedirs(folder, exist_ok=True)
    return mannequin(folder), [garment(folder, n) for n in names]
