"""The dressing room as one self-contained HTML file (:file:`room.html` + :file:`room.js`).

Every picture is a PNG data URI: the mannequin at full canvas size; each garment cropped
to the box where it shows (``at``: its top-left corner on the canvas) and its depth image
cropped to the same box (:func:`puppet.room.depth.depth_rgba`). The page composites with
a 2D canvas: the mannequin, then the worn garments in draw order, each drawn "over".

Layout: ``#room-meta`` holds the JSON (canvas, categories, garments in draw order with
name, category, order, at, size, image and depth).
"""
from __future__ import annotations

import html
import os
from importlib import resources

import numpy as np

from puppet.anim.web import fill, png_uri, script_code, script_json, utf8
from puppet.room.depth import LOW, STEPS, depth_rgba
from puppet.room.model import Room
from puppet.scene.format.garment import CATEGORIES

#: Largest single-file room the command writes, bytes (a page this size opens in a second).
MAX_BYTES = 64 << 20


def crop_box(alpha: np.ndarray) -> tuple[int, int, int, int]:
    """(x, y, w, h) of the smallest box holding every pixel with alpha > 0 (a 1x1 box at
    the origin when there is none)."""
    ys, xs = np.nonzero(alpha > 0)
    if not len(ys):
        return 0, 0, 1, 1
    return int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1)


def garment_entry(g) -> dict:
    x, y, w, h = crop_box(g.rgba[..., 3])
    box = (slice(y, y + h), slice(x, x + w))
    return {"name": utf8(g.name), "category": g.category, "order": g.order, "at": [x, y], "size": [w, h],
            "image": png_uri(g.rgba[box]), "depth": png_uri(depth_rgba(g.depth[box]))}


def room_html(room: Room, title: str) -> str:
    """The page's text."""
    meta = {"room": 1, "canvas": list(room.canvas), "categories": list(CATEGORIES),
            "depthCode": [LOW, STEPS], "mannequin": png_uri(room.mannequin),
            "garments": [garment_entry(g) for g in room.garments]}
    w, h = room.canvas
    template = resources.files("puppet.room").joinpath("room.html").read_text("utf-8")
    script = resources.files("puppet.room").joinpath("room.js").read_text("utf-8")
    return fill(template, {"title": html.escape(utf8(os.path.basename(title))), "width": str(w), "height": str(h),
                           "meta": script_json(meta), "script": script_code(script)})
