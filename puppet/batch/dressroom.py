"""``puppet batch --template ... --dressroom MANNEQUIN``: every matched picture also becomes
a dressing-room garment (:mod:`puppet.room`) on the template's canvas, which is the
mannequin's, and the batch ends by writing ``OUT_DIR/room/``.

On the worker, a template job that matched its picture (:func:`write_garment`):

1. resamples the picture's garment (its pixels under the transferred mask rule, alpha
   zero elsewhere; premultiplied bilinear) into the template's coordinates by the inverse
   of the aligning similarity ``S`` (template -> picture), cropped to the box it covers
   there, written as ``OUT_DIR/garments/STEM.png``;
2. writes ``OUT_DIR/garments/STEM.json``: a one-layer scene on the template's canvas over
   that picture (mask ``alpha``), the transferred pins, cage and pose targets mapped back
   by ``S^-1`` (so they sit near the template's own), the pose ``fit`` = the transferred
   pose ``NAME`` mapped back (the garment is drawn as the template sits on the mannequin
   in ``NAME``), and a ``garment`` section (name: the output's stem, category: the
   template's, else ``top``);

then, on the client, once every job ran (:func:`make_room`): the room of the mannequin
and every garment written (up to date ones of an earlier run too), in the folder form
(:func:`puppet.room.page.write_room_folder`) at ``OUT_DIR/room/``. A garment the room
refuses is left out and reported; the room itself is never a failed job.
"""
from __future__ import annotations

import copy
import json
import os

import cv2
import numpy as np

from puppet.batch.template import NUDGE, Transfer, on_mask
from puppet.errors import SceneError
from puppet.geom.outline_match import Similarity
from puppet.output import check_folder, save_png, write_folder, write_text
from puppet.room.model import FIT_POSE, Room, draw_order, load_garment
from puppet.room.page import PICTURE_NAME, PICTURES, write_room_folder

#: Folder of OUT_DIR holding the room (index.html, pictures/).
ROOM = "room"


def _back(S: Similarity, P) -> np.ndarray:
    """Picture points -> template points (``S^-1``), (..., 2)."""
    P = np.asarray(P, np.float64)
    z = (P[..., 0] + 1j * P[..., 1] - S.b) / S.a
    return np.stack([z.real, z.imag], axis=-1)


def _xy(p) -> list[float]:
    return [round(float(p[0]), 3), round(float(p[1]), 3)]


def resample(rgba: np.ndarray, mask: np.ndarray, S: Similarity, canvas) -> tuple[np.ndarray, tuple[int, int]]:
    """The picture's garment (``rgba`` where ``mask``, clear elsewhere) seen in template
    coordinates: ``(crop, (x, y))``, the crop's top-left corner on the template's canvas.

    Pixel centres are at +0.5 on both canvases; the crop is the box (1 px margin, clipped
    to ``canvas``) around the image of the mask's box under ``S^-1``; bilinear over
    premultiplied colour, so clear pixels lend no colour to the edge. Raises SceneError
    when the garment lands outside the canvas."""
    ys, xs = np.nonzero(mask)
    if not len(ys):
        raise SceneError("the picture's mask is empty")
    corners = np.array([[xs.min(), ys.min()], [xs.max() + 1, ys.min()], [xs.min(), ys.max() + 1],
                        [xs.max() + 1, ys.max() + 1]], np.float64)
    box = _back(S, corners)
    W, H = canvas
    x0, y0 = (max(int(np.floor(v)) - 1, 0) for v in box.min(axis=0))
    x1, y1 = min(int(np.ceil(box[:, 0].max())) + 1, W), min(int(np.ceil(box[:, 1].max())) + 1, H)
    if x1 <= x0 or y1 <= y0:
        raise SceneError(f"the garment lands outside the template's {W}x{H} canvas")
    a = rgba.astype(np.float32)
    a[..., 3] = np.where(mask, a[..., 3], 0.0)
    a[..., :3] *= a[..., 3:] / 255.0
    c = 0.5 + 0.5j  # cv2 samples at integer indices: pixel centres
    t = S.a * (complex(x0, y0) + c) + S.b - c  # crop index p -> picture index S.a p + t
    M = np.array([[S.a.real, -S.a.imag, t.real], [S.a.imag, S.a.real, t.imag]])
    out = cv2.warpAffine(a, M, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0))
    alpha = out[..., 3:]
    rgb = np.divide(out[..., :3] * 255.0, alpha, out=np.zeros_like(out[..., :3]), where=alpha > 0)
    crop = np.rint(np.concatenate([rgb, alpha], axis=2)).clip(0, 255).astype(np.uint8)
    return crop, (x0, y0)


def _targets(pose: dict, S: Similarity) -> dict:
    """A pose's (or key's) pin targets mapped back by ``S^-1`` (``None`` kept)."""
    out = {}
    for nm, t in pose.items():
        if isinstance(t, list):
            t = _xy(_back(S, t))
        elif isinstance(t, dict) and "to" in t:
            t = dict(t, to=_xy(_back(S, t["to"])))
        out[nm] = t
    return out


def garment_doc(tr: Transfer, pose: str, image: str, crop: np.ndarray, at: tuple[int, int], *, canvas,
                name: str, category: str) -> dict:
    """The room garment's scene (``image``: its picture's path as the scene names it)."""
    S, src = tr.similarity, tr.scene
    layer = {k: copy.deepcopy(v) for k, v in src["layers"][0].items() if k not in ("image", "mask", "cage")}
    layer.update(image=image, offset=[int(at[0]), int(at[1])], mask="alpha")
    cage = src["layers"][0].get("cage")
    if cage is not None:
        layer["cage"] = dict(copy.deepcopy(cage), points=[_xy(p) for p in _back(S, cage["points"])])
        if "offset" in cage:
            layer["cage"]["offset"] = min(round(cage["offset"] / S.scale, 1), 1000.0)
    doc = {"puppet": 1, "canvas": list(canvas), "garment": {"name": name, "category": category},
           "layers": [layer], "pins": _pins(src["pins"], S, crop[..., 3] > 0, at)}
    for key in ("deformer", "bones", "physics"):
        if key in src:
            doc[key] = copy.deepcopy(src[key])
    poses = {k: _targets(v, S) for k, v in src.get("poses", {}).items()}
    poses[FIT_POSE] = poses[pose]
    doc["poses"] = poses
    if "animation" in src:
        anim = copy.deepcopy(src["animation"])
        for key in anim.get("keys", []):
            for f in ("pins", "overrides"):
                if isinstance(key.get(f), dict):
                    key[f] = _targets(key[f], S)
        doc["animation"] = anim
    return doc


def _pins(pins: list[dict], S: Similarity, mask: np.ndarray, at) -> list[dict]:
    """The transferred pins mapped back by ``S^-1``; an interior pin that the resampling
    left just off the garment's pixels is moved onto the nearest one (at most
    :data:`~puppet.batch.template.NUDGE` px, else SceneError)."""
    out = []
    off = np.asarray(at, np.float64)
    for p in pins:
        x = _back(S, p["at"])
        if p.get("kind", "interior") != "exterior":
            y, far = on_mask(mask, x - off)
            if far > NUDGE:
                raise SceneError(f"pin {p['name']!r} lands off the resampled garment")
            x = y + off
        out.append(dict(p, at=_xy(x)))
    return out


def write_garment(job: dict, tr: Transfer, *, inputs) -> None:
    """Write the room garment of a matched template job (``job["room"]``: its ``scene``
    and ``picture`` paths, the template's ``canvas`` and ``category``): the picture, then
    the scene (a scene is there only with its picture; the job is done once both are)."""
    room = job["room"]
    crop, at = resample(tr.picture, tr.mask, tr.similarity, room["canvas"])
    doc = garment_doc(tr, job["pose"], os.path.basename(room["picture"]), crop, at, canvas=room["canvas"],
                      name=os.path.splitext(job["rel"])[0], category=room["category"])
    folder = os.path.dirname(room["scene"])
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as e:
        raise SceneError(f"cannot create the folder: {e.strerror or e}", file=folder) from None
    save_png(room["picture"], crop, inputs=inputs)
    write_text(room["scene"], json.dumps(doc, indent=1) + "\n", inputs=inputs)


def _room_entry(folder: str, name: str) -> bool:
    """An entry an earlier batch's room left in ``OUT_DIR/room/`` (replaced as a whole):
    ``index.html``, and ``pictures/`` holding only its pictures (regular files)."""
    path = os.path.join(folder, name)
    if name == "index.html":
        return os.path.isfile(path) and not os.path.islink(path)
    if name != PICTURES or os.path.islink(path) or not os.path.isdir(path):
        return False
    return all(PICTURE_NAME.fullmatch(n) and os.path.isfile(os.path.join(path, n))
               and not os.path.islink(os.path.join(path, n)) for n in os.listdir(path))


def check_room_folder(folder: str, inputs) -> None:
    """``OUT_DIR/room/`` can be written (new, or an earlier batch's room); SceneError if not."""
    check_folder(folder, inputs=inputs, own=_room_entry)


def garments(room: list[str], canvas, mannequin: str, say) -> tuple[list, list[dict]]:
    """The garments of the scenes ``room`` (``puppet.room.model.Garment``, in draw
    order) and the refused ones (``{"garment": path, "error": one line}``): a garment the
    room refuses (it cannot be drawn, its name is taken) is left out and said."""
    loaded, refused, names = [], [], {}
    for path in room:
        try:
            g = load_garment(path, canvas, mannequin)
            if g.name in names:
                raise SceneError(f"garment name {g.name!r} is also the name of {names[g.name]}", file=path)
        except SceneError as e:
            line = str(e).strip().splitlines()[0]
            refused.append({"garment": path, "error": line})
            say(f"puppet batch: dressroom: left out: {line}")
            continue
        names[g.name] = path
        loaded.append(g)
    return draw_order(loaded), refused


def make_room(out_dir: str, mannequin: np.ndarray, mannequin_file: str, scenes: list[str], *, inputs,
              say=lambda s: None) -> dict:
    """Write ``OUT_DIR/room/`` (the folder form) of ``mannequin`` and the garment scenes
    ``scenes``; what the report says of it."""
    h, w = mannequin.shape[:2]
    worn, refused = garments(scenes, (w, h), mannequin_file, say)
    folder = os.path.join(out_dir, ROOM)
    room = Room(mannequin=mannequin, garments=worn)
    write_folder(folder, lambda tmp: write_room_folder(room, tmp, folder), inputs=inputs, own=_room_entry)
    return {"folder": f"{ROOM}/", "garments": [g.name for g in worn], "refused": refused}
