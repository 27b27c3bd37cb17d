"""The dressing room as a web page (:file:`room.html` + :file:`room.js`), in one of two forms:

- one self-contained HTML file (:func:`room_html`): every picture a PNG data URI;
- a folder (:func:`write_room_folder`): ``index.html`` and the pictures beside it in
  ``pictures/`` (``mannequin.png``; per garment, numbered in draw order, ``N.png`` and
  ``N-depth.png``; the thumbnails, at most :data:`THUMB` pixels a side, on sheets of
  :data:`SHEET` x :data:`SHEET` cells, ``thumbs-K.png``), which the page loads as it needs
  them: for catalogues of thousands. A screen of 165 thumbnails (a 1920 x 1080 window)
  then costs 3 sheets, not 165 pictures.

A garment's picture is cropped to the box where it shows (``at``: its top-left corner on
the canvas) and its depth image to the same box (:func:`puppet.room.depth.depth_rgba`).
The page composites with a 2D canvas: the mannequin, then the worn garments in draw
order, each drawn "over".

Layout: ``#room-meta`` holds the JSON (canvas, categories, the depth code, the mannequin,
the garments in draw order with name, category, order, at, size, image, depth and, in
the folder form, thumb: ``{"sheet", "at", "size", "sheetSize"}``, its cell on a sheet).
"""
from __future__ import annotations

import base64
import html
import os
import re
from importlib import resources

import numpy as np
from PIL import Image

from puppet.anim.web import fill, script_code, script_json, utf8
from puppet.output import encode_png
from puppet.room.depth import LOW, STEPS, depth_rgba
from puppet.room.model import Room
from puppet.scene.format.garment import CATEGORIES

#: Largest single-file room the command writes, bytes (above it: the folder form).
MAX_BYTES = 64 << 20
#: Largest side of a thumbnail in the folder form, pixels (twice the shelf's 72 px).
THUMB = 144
#: Thumbnails a side of a thumbnail sheet (a sheet holds SHEET x SHEET of them).
SHEET = 8
#: zlib level of the page's PNGs (OpenCV, filter "up"). A 297 x 247 t-shirt crop: its
#: picture 23.5 KB in 3.8 ms and its depth image 13.5 KB in 7.7 ms, against 20.6 KB in
#: 29 ms and 12.4 KB in 90 ms from Pillow at level 9; the thumbnail sheets too.
LEVEL = 6
#: ... of the pictures a batch's workers draw (:mod:`puppet.batch.dressroom`), where time
#: counts: 25.7 KB in 2.5 ms and 17.4 KB in 2.4 ms.
FAST_LEVEL = 3
PICTURES = "pictures"
#: The names :func:`write_room_folder` gives the files of ``pictures/``.
PICTURE_NAME = re.compile(r"mannequin\.png|\d{4,}(-depth)?\.png|thumbs-\d{3,}\.png")


def thumbnail(rgba: np.ndarray) -> np.ndarray:
    """``rgba`` scaled (Lanczos) so that its longer side is :data:`THUMB` pixels: every
    cell of a sheet is shown at one scale, never a small garment's sheet blown up in the
    page (a 10 px crop's sheet would be drawn 8000 px wide)."""
    im = Image.fromarray(np.ascontiguousarray(rgba), "RGBA")
    w, h = im.size
    k = THUMB / max(w, h)
    return np.asarray(im.resize((max(1, round(w * k)), max(1, round(h * k))), Image.LANCZOS))


def thumb_sheets(room: Room, picture) -> list[dict]:
    """Every garment's thumbnail placed on sheets of :data:`SHEET` x :data:`SHEET` cells of
    :data:`THUMB` px, written with ``picture(name, rgba)``; per garment its ``thumb`` entry."""
    cell, per = THUMB, SHEET * SHEET
    thumbs = [g.thumb if g.thumb is not None else thumbnail(g.rgba) for g in room.garments]
    out = []
    for first in range(0, len(thumbs), per):
        part = thumbs[first:first + per]
        rows = -(-len(part) // SHEET)
        sheet = np.zeros((rows * cell, min(len(part), SHEET) * cell, 4), np.uint8)
        places = []
        for k, t in enumerate(part):
            x, y = (k % SHEET) * cell, (k // SHEET) * cell
            sheet[y:y + t.shape[0], x:x + t.shape[1]] = t
            places.append(([x, y], [int(t.shape[1]), int(t.shape[0])]))
        name = picture(f"thumbs-{first // per + 1:03d}.png", encode(sheet))
        out += [{"sheet": name, "at": at, "size": size, "sheetSize": [sheet.shape[1], sheet.shape[0]]}
                for at, size in places]
    return out


def _meta(room: Room, picture, thumbs: bool) -> dict:
    """The page's JSON; ``picture(name, rgba or PNG bytes)`` gives the address of a picture."""
    garments = []
    sheets = thumb_sheets(room, picture) if thumbs else None
    for n, g in enumerate(room.garments, 1):
        image, depth = g.png if g.png is not None else (g.rgba, depth_rgba(g.depth))
        entry = {"name": utf8(g.name), "category": g.category, "order": g.order, "at": list(g.at),
                 "size": list(g.size), "image": picture(f"{n:04d}.png", image),
                 "depth": picture(f"{n:04d}-depth.png", depth)}
        if sheets is not None:
            entry["thumb"] = sheets[n - 1]
        garments.append(entry)
    return {"room": 1, "canvas": list(room.canvas), "categories": list(CATEGORIES), "depthCode": [LOW, STEPS],
            "mannequin": picture("mannequin.png", room.mannequin), "garments": garments}


def _page(room: Room, title: str, meta: dict) -> str:
    w, h = room.canvas
    template = resources.files("puppet.room").joinpath("room.html").read_text("utf-8")
    script = resources.files("puppet.room").joinpath("room.js").read_text("utf-8")
    return fill(template, {"title": html.escape(utf8(os.path.basename(title.rstrip("/" + os.sep)))),
                           "width": str(w), "height": str(h), "meta": script_json(meta),
                           "script": script_code(script)})


def encode(rgba: np.ndarray, level: int = LEVEL) -> bytes:
    """A page picture as PNG (:func:`puppet.output.encode_png`)."""
    return encode_png(rgba, level=level)


def uri(image) -> str:
    """A picture (an array or PNG bytes) as a data URI."""
    data = image if isinstance(image, bytes) else encode(image)
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def room_html(room: Room, title: str) -> str:
    """The single-file page's text."""
    return _page(room, title, _meta(room, lambda name, image: uri(image), thumbs=False))


def write_room_folder(room: Room, folder: str, title: str) -> int:
    """Write ``index.html`` and ``pictures/`` into the (new, empty) ``folder``; returns
    the number of pictures."""
    os.makedirs(os.path.join(folder, PICTURES))
    count = 0

    def picture(name: str, image) -> str:
        nonlocal count
        with open(os.path.join(folder, PICTURES, name), "wb") as f:
            f.write(image if isinstance(image, bytes) else encode(image))
        count += 1
        return f"{PICTURES}/{name}"
    text = _page(room, title, _meta(room, picture, thumbs=True))
    with open(os.path.join(folder, "index.html"), "w", encoding="utf-8") as f:
        f.write(text)
    return count
