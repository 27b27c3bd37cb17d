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
   template's, else ``top``); automatic exterior points renamed as the resampled
   picture numbers them (:func:`_ext_names`);
3. draws the room's pictures from the job's own solve (:func:`draw_posed`: the posed mesh
   moved by ``S^-1``, over that picture) and writes them with the garment's place and the
   digests of the files above as ``OUT_DIR/garments/STEM.room.zip`` (:func:`write_drawn`);

then, on the client, once every job ran (:func:`make_room`): the room of the mannequin
and every garment written (up to date ones of an earlier run too), in the folder form
(:func:`puppet.room.page.write_room_folder`) at ``OUT_DIR/room/``: a garment's pictures
those its job drew (:func:`read_drawn`), or, for a garment scene edited since or a
drawn file missing or spoiled, the scene drawn by the client. A garment the room
refuses is left out and reported; the room itself is never a failed job.
"""
from __future__ import annotations

import copy
import hashlib
import json
import os
import zipfile

import cv2
import numpy as np

from puppet.batch.jobs import DRAWN
from puppet.batch.template import NUDGE, Transfer, on_mask
from puppet.errors import SceneError, one_line
from puppet.geom.outline_match import Similarity
from puppet.imaging import masks as mk
from puppet.output import atomic_write, check_folder, encode_png, write_bytes, write_folder, write_text
from puppet.room import page
from puppet.room.depth import depth_rgba
from puppet.room.model import CLEAR, FIT_POSE, Garment, Room, box_frame, cropped, load_garment, load_garments
from puppet.room.page import PICTURE_NAME, PICTURES, write_room_folder
from puppet.scene.rig.exterior import auto_points

#: Folder of OUT_DIR holding the room (index.html, pictures/).
ROOM = "room"


def _xy(p) -> list[float]:
    return [round(float(p[0]), 3), round(float(p[1]), 3)]


def resample(rgba: np.ndarray, mask: np.ndarray, S: Similarity, canvas) -> tuple[np.ndarray, tuple[int, int]]:
    """The picture's garment (``rgba`` where ``mask``, clear elsewhere) seen in template
    coordinates: ``(crop, (x, y))``, the crop's top-left corner on the template's canvas.

    Pixel centres are at +0.5 on both canvases; the crop is the box (1 px margin, clipped
    to ``canvas``) around the image of the mask's box under ``S^-1``; bilinear over
    premultiplied colour (16 bits), so clear pixels lend no colour to the edge. A picture
    k >= 2 times the template's scale is first averaged over k x k blocks, so a crop pixel
    shows the picture's pixels it covers, not a sample of them. Raises SceneError
    when the garment lands outside the canvas."""
    m8 = np.ascontiguousarray(mask, np.uint8)
    mx, my, mw, mh = cv2.boundingRect(m8)
    if not mw:
        raise SceneError("the picture's mask is empty")
    corners = np.array([[mx, my], [mx + mw, my], [mx, my + mh], [mx + mw, my + mh]], np.float64)
    box = S.inverse().apply(corners)
    W, H = canvas
    x0, y0 = (max(int(np.floor(v)) - 1, 0) for v in box.min(axis=0))
    x1, y1 = min(int(np.ceil(box[:, 0].max())) + 1, W), min(int(np.ceil(box[:, 1].max())) + 1, H)
    if x1 <= x0 or y1 <= y0:
        raise SceneError(f"the garment lands outside the template's {W}x{H} canvas")
    # only the mask's box (and a pixel round it, which bilinear samples reach) is read
    bx0, by0 = max(mx - 1, 0), max(my - 1, 0)
    bx1, by1 = min(mx + mw + 1, rgba.shape[1]), min(my + mh + 1, rgba.shape[0])
    c = 0.5 + 0.5j  # cv2 samples at integer indices: pixel centres
    t = S.a * (complex(x0, y0) + c) + S.b - c - complex(bx0, by0)  # crop index p -> box index S.a p + t
    # premultiplied in 16 bits (0..255^2) by OpenCV, the mask's outside cleared
    r, g, b, alpha = cv2.split(np.ascontiguousarray(rgba[by0:by1, bx0:bx1]))
    alpha = cv2.multiply(alpha, m8[by0:by1, bx0:bx1])
    pm = cv2.merge([cv2.multiply(p, alpha, dtype=cv2.CV_16U) for p in (r, g, b)]
                   + [cv2.multiply(alpha, 255, dtype=cv2.CV_16U)])
    k, A = int(abs(S.a)), S.a
    if k >= 2:  # a picture k times the template or more: averaged over k x k blocks first (what
        # the crop's pixels cover; and the warp of a k^2 times smaller picture)
        h, w = -(-pm.shape[0] // k) * k, -(-pm.shape[1] // k) * k
        pm = cv2.copyMakeBorder(pm, 0, h - pm.shape[0], 0, w - pm.shape[1], cv2.BORDER_CONSTANT, value=0)
        pm = cv2.resize(pm, (w // k, h // k), interpolation=cv2.INTER_AREA)
        t, A = (t + c) / k - c, S.a / k  # box pixel centre q + 0.5 is block coordinate (q + 0.5) / k
    M = np.array([[A.real, -A.imag, t.real], [A.imag, A.real, t.imag]])
    out = cv2.warpAffine(pm, M, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0)).astype(np.float32)
    out *= np.float32(1 / 255)
    alpha = out[..., 3:]
    out[..., :3] *= np.divide(np.float32(255), alpha, out=np.zeros_like(alpha), where=alpha > 0)
    np.rint(out, out=out)
    crop = np.clip(out, 0, 255, out=out).astype(np.uint8)
    return crop, (x0, y0)


def _targets(pose: dict, S: Similarity, names: dict | None = None) -> dict:
    """A pose's (or key's) pin targets mapped back by ``S^-1`` (``None`` kept); a pin
    named in ``names`` renamed, or left out when it maps to None (:func:`_ext_names`)."""
    out = {}
    for nm, t in pose.items():
        if names and nm in names:
            if names[nm] is None:
                continue
            nm = names[nm]
        if isinstance(t, list):
            t = _xy(S.inverse().apply(t))
        elif isinstance(t, dict) and "to" in t:
            t = dict(t, to=_xy(S.inverse().apply(t["to"])))
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
        layer["cage"] = dict(copy.deepcopy(cage), points=[_xy(p) for p in S.inverse().apply(cage["points"])])
        if "offset" in cage:
            layer["cage"]["offset"] = min(round(cage["offset"] / S.scale, 1), 1000.0)
    doc = {"puppet": 1, "canvas": list(canvas), "garment": {"name": name, "category": category},
           "layers": [layer], "pins": _pins(src["pins"], S, crop[..., 3] > 0, at)}
    for key in ("deformer", "bones", "physics"):
        if key in src:
            doc[key] = copy.deepcopy(src[key])
    names = _ext_names(tr, crop, at)
    poses = {k: _targets(v, S, names) for k, v in src.get("poses", {}).items()}
    poses[FIT_POSE] = poses[pose]
    doc["poses"] = poses
    if "animation" in src:
        anim = copy.deepcopy(src["animation"])
        for key in anim.get("keys", []):
            for f in ("pins", "overrides"):
                if isinstance(key.get(f), dict):
                    key[f] = _targets(key[f], S, names)
        doc["animation"] = anim
    if names and "physics" in doc:
        for chain in doc["physics"].get("chains", []):
            chain["pins"] = [names.get(p, p) or p for p in chain["pins"]]
    return doc


def _ext_names(tr: Transfer, crop: np.ndarray, at) -> dict[str, str | None]:
    """The picture's automatic exterior points (``LAYER:extI``, made on its mask) -> the
    room garment's (``LAYER:extJ``, made again on the resampled picture's alpha, numbered
    by its own outline): matched one-to-one by place, the picture's points moved by
    ``S^-1``; None for a point with no counterpart within a tenth of the garment's size
    (its targets are dropped, as the template transfer drops them). Empty without
    automatic exterior points."""
    layer = tr.scene["layers"][0]
    ext = layer.get("exterior")
    if not isinstance(ext, dict) or not ext.get("auto", True):
        return {}
    beta = float(ext.get("beta", 1.0))
    picture = auto_points(tr.mask, (0.0, 0.0), beta)
    mask = mk.alpha_mask(crop)
    garment = auto_points(mask, tuple(float(v) for v in at), beta)
    out: dict[str, str | None] = {f"{layer['name']}:ext{i}": None for i in range(len(picture))}
    if len(picture) and len(garment):
        from scipy.optimize import linear_sum_assignment  # lazy: only templates with automatic exterior points

        D = np.linalg.norm(tr.similarity.inverse().apply(picture)[:, None] - garment[None], axis=2)
        r, c = linear_sum_assignment(D)
        gate = 0.1 * np.sqrt(mask.sum())
        out.update({f"{layer['name']}:ext{i}": f"{layer['name']}:ext{j}" for i, j in zip(r, c) if D[i, j] <= gate})
    return out


def _pins(pins: list[dict], S: Similarity, mask: np.ndarray, at) -> list[dict]:
    """The transferred pins mapped back by ``S^-1``; an interior pin that the resampling
    left just off the garment's pixels is moved onto the nearest one (at most
    :data:`~puppet.batch.template.NUDGE` px, else SceneError)."""
    out = []
    off = np.asarray(at, np.float64)
    for p in pins:
        x = S.inverse().apply(p["at"])
        if p.get("kind", "interior") != "exterior":
            y, far = on_mask(mask, x - off)
            if far > NUDGE:
                raise SceneError(f"pin {p['name']!r} lands off the resampled garment")
            x = y + off
        out.append(dict(p, at=_xy(x)))
    return out


def write_garment(job: dict, tr: Transfer, scene, layers, *, inputs) -> None:
    """Write the room garment of a matched template job (``job["room"]``: its ``scene``,
    ``picture`` and ``drawn`` paths, the template's ``canvas`` and ``category``): the
    picture, the scene, then the room's pictures drawn from the job's own posed
    ``layers`` of ``scene`` over the resampled picture (:func:`write_drawn`). A scene is
    there only with its picture; the job is done once all three are."""
    if len(layers) != 1:
        raise SceneError(f"a room garment has one layer, the transferred scene {len(layers)}")
    room = job["room"]
    crop, at = resample(tr.picture, tr.mask, tr.similarity, room["canvas"])
    name = os.path.splitext(job["rel"])[0]
    doc = garment_doc(tr, job["pose"], os.path.basename(room["picture"]), crop, at, canvas=room["canvas"],
                      name=name, category=room["category"])
    folder = os.path.dirname(room["scene"])
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as e:
        raise SceneError(f"cannot create the folder: {e.strerror or e}", file=folder) from None
    picture = encode_png(crop)
    text = json.dumps(doc, indent=1) + "\n"
    write_bytes(room["picture"], picture, inputs=inputs)
    write_text(room["scene"], text, inputs=inputs)
    write_drawn(room["drawn"], scene.compositor, layers[0], crop, at, tr.similarity, room["canvas"], inputs=inputs,
                meta={"name": name, "category": room["category"], "order": 0.0,
                      "scene": _digest(text.encode("utf-8")), "picture": _digest(picture)})


#: The members of a garment's ``STEM.room.zip`` (:func:`write_drawn`).
MEMBERS = ("meta.json", "picture.png", "depth.png", "thumb.png")


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def draw_posed(compositor, posed, crop: np.ndarray, at, S: Similarity, canvas):
    """The room's picture of a job's garment: its posed layer (the job's one layer, a
    :class:`~puppet.scene.rig.core.LayerResult`) moved by ``S^-1`` onto the template's
    ``canvas`` and drawn with the resampled picture ``crop`` (its corner at ``at``) as its
    texture, in a box round it; ``(rgba, depth, at)`` as :func:`puppet.room.model.draw_garment`
    gives them. The texture in the template's pixels, not the picture's: a catalogue photo
    several times the template's size is drawn from its averaged pixels, not sampled."""
    from puppet.render.layers import DrawLayer  # lazy: drawing only

    deformed = S.inverse().apply(posed.deformed)
    x0, y0, frame = box_frame(deformed, canvas)
    layer = DrawLayer(key=posed.name + "\0room", image=crop, offset=(float(at[0]), float(at[1])),
                      rest=S.inverse().apply(posed.rest), deformed=deformed - (x0, y0), triangles=posed.triangles,
                      depth=posed.depth)
    rgba = compositor.render([layer], frame, background=CLEAR)
    return cropped(rgba, compositor.pin_depth([layer], frame, [posed.order]), (x0, y0), canvas)


def write_drawn(path: str, compositor, posed, crop: np.ndarray, at, S: Similarity, canvas, *, meta: dict,
                inputs) -> None:
    """``STEM.room.zip``: the garment's room pictures (its picture and depth image as the
    room's page shows them, and its thumbnail; :func:`draw_posed`), with ``meta.json``
    (the garment's name, category, order, its box's corner ``at`` and ``size``, and the
    SHA-256 of the garment scene and picture it belongs to: the room uses the pictures
    only while those files are unchanged). Stored (not compressed: the PNGs are)."""
    rgba, depth, at = draw_posed(compositor, posed, crop, at, S, tuple(canvas))
    meta = dict(meta, at=[int(at[0]), int(at[1])], size=[int(rgba.shape[1]), int(rgba.shape[0])])
    parts = (json.dumps(meta).encode("utf-8"), page.encode(rgba, page.FAST_LEVEL),
             page.encode(depth_rgba(depth), page.FAST_LEVEL), page.encode(page.thumbnail(rgba), page.FAST_LEVEL))

    def write(tmp: str) -> None:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED) as z:
            for name, data in zip(MEMBERS, parts):
                z.writestr(name, data)
    atomic_write(path, write, inputs=inputs)


def read_drawn(scene_path: str) -> Garment | None:
    """The garment a job drew for the room (``STEM.room.zip`` beside ``scene_path``), if
    it is there, whole, and belongs to the garment scene and picture as they are now;
    else None (the room draws the scene itself)."""
    base = scene_path[:-len(".json")] if scene_path.endswith(".json") else scene_path
    try:
        with zipfile.ZipFile(base + DRAWN) as z:
            meta, picture, depth, thumb = (z.read(n) for n in MEMBERS)
        meta = json.loads(meta)
        with open(scene_path, "rb") as f:
            scene_text = f.read()
        if meta["scene"] != _digest(scene_text):
            return None
        image = json.loads(scene_text)["layers"][0]["image"]
        with open(os.path.join(os.path.dirname(scene_path), image), "rb") as f:
            if meta["picture"] != _digest(f.read()):
                return None
        rgba, small = decode_png(picture), decode_png(thumb)
        w, h = meta["size"]
        if rgba.shape[:2] != (h, w):
            return None
        return Garment(name=meta["name"], category=meta["category"], order=float(meta["order"]), file=scene_path,
                       rgba=rgba, depth=None, at=(int(meta["at"][0]), int(meta["at"][1])), png=(picture, depth),
                       thumb=small)
    except (OSError, KeyError, ValueError, TypeError, IndexError, zipfile.BadZipFile):
        return None


def decode_png(data: bytes) -> np.ndarray:
    """PNG bytes as (h, w, 4) straight RGBA uint8; ValueError if they are not a picture."""
    a = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if a is None or a.ndim != 3 or a.shape[2] != 4 or a.dtype != np.uint8:
        raise ValueError("not an RGBA PNG")
    return cv2.cvtColor(a, cv2.COLOR_BGRA2RGBA)


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
    order; those its jobs drew, :func:`read_drawn`, else drawn here) and the refused
    ones (``{"garment": path, "error": one line}``): a garment the room refuses (it cannot
    be drawn, its name is taken) is left out and said."""
    refused = []

    def left_out(path: str, e: SceneError) -> None:
        line = one_line(e)
        refused.append({"garment": path, "error": line})
        say(f"puppet batch: dressroom: left out: {line}")
    loaded = load_garments(room, canvas, mannequin, left_out=left_out,
                           load=lambda path: read_drawn(path) or load_garment(path, canvas, mannequin))
    return loaded, refused


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
