"""The dressing room's content: the mannequin and the garments rendered on its canvas.

A garment is a scene rendered at its pose ``fit`` (else at rest) over a clear background,
with its per-pixel pin depth (drawn on the GPU, :meth:`puppet.api.Scene.pin_depth`;
:mod:`puppet.room.depth` codes it for the page), both cropped to where it shows (a
room of a thousand garments keeps its crops, not a thousand canvases). Garments are drawn in
:func:`draw_order`: by category (:data:`~puppet.scene.format.garment.CATEGORIES`, back
to front), then ``order``, then the order they were given in.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import cv2
import numpy as np

import puppet
from puppet.errors import SceneError
from puppet.imaging.io import load_rgba
from puppet.room.depth import grow
from puppet.scene.format.garment import CATEGORIES, DEFAULT_CATEGORY

#: Frame sizes of garments drawn in a box (:func:`box_frame`) are multiples of this, px.
FRAME = 64
#: The pose a garment is shown in when its scene has one.
FIT_POSE = "fit"
CLEAR = (0, 0, 0, 0)


@dataclass(frozen=True)
class Garment:
    """One garment, cropped to the box where it shows: ``rgba`` (h, w, 4) straight uint8,
    its top-left corner at ``at`` on the mannequin's canvas; ``depth`` (h, w) float64 over
    the same box, NaN where the garment does not show. A garment drawn elsewhere (by a
    batch's worker, :mod:`puppet.batch.dressroom`) may bring its page pictures already
    encoded: ``png`` = (picture, depth image) PNG bytes, and its ``thumb``; its ``depth``
    is then None."""

    name: str
    category: str
    order: float
    file: str
    rgba: np.ndarray
    depth: np.ndarray | None
    at: tuple[int, int] = (0, 0)
    png: tuple[bytes, bytes] | None = None
    thumb: np.ndarray | None = None

    @property
    def size(self) -> tuple[int, int]:
        h, w = self.rgba.shape[:2]
        return w, h

    def on_canvas(self, canvas: tuple[int, int]) -> np.ndarray:
        """The garment's picture placed on a clear ``canvas`` = (W, H), (H, W, 4)."""
        W, H = canvas
        out = np.zeros((H, W, 4), np.uint8)
        (x, y), (w, h) = self.at, self.size
        out[y:y + h, x:x + w] = self.rgba
        return out

    def depth_on_canvas(self, canvas: tuple[int, int]) -> np.ndarray:
        """The garment's depth placed on a ``canvas`` = (W, H) of NaN, (H, W)."""
        W, H = canvas
        out = np.full((H, W), np.nan)
        (x, y), (w, h) = self.at, self.size
        out[y:y + h, x:x + w] = self.depth
        return out


@dataclass(frozen=True)
class Room:
    """``mannequin`` (H, W, 4) straight uint8; ``garments`` in draw order."""

    mannequin: np.ndarray
    garments: list[Garment]

    @property
    def canvas(self) -> tuple[int, int]:
        h, w = self.mannequin.shape[:2]
        return w, h


def is_scene(path: str) -> bool:
    return os.path.splitext(path)[1].lower() == ".json"


def load_mannequin(path: str) -> np.ndarray:
    """A picture as it is, or a scene rendered at rest (over its own background)."""
    if not is_scene(path):
        return load_rgba(path)
    scene = puppet.load_scene(path)
    try:
        return scene.render(pose="rest")
    finally:
        scene.close()


def crop_box(alpha: np.ndarray) -> tuple[int, int, int, int]:
    """(x, y, w, h) of the smallest box holding every pixel with alpha > 0 (a 1x1 box at
    the origin when there is none)."""
    x, y, w, h = cv2.boundingRect(np.ascontiguousarray(alpha > 0, np.uint8))
    return (0, 0, 1, 1) if not w else (int(x), int(y), int(w), int(h))


def draw_garment(scene, layers, canvas: tuple[int, int]):
    """The garment of ``scene``'s posed ``layers`` over a clear background, drawn over the
    whole ``canvas`` = (W, H) (the pixels of ``puppet render``), cropped to where it
    shows: ``(rgba, depth, at)`` (see :class:`Garment`)."""
    rgba = scene.draw_layers(layers, background=CLEAR, canvas=canvas)
    return cropped(rgba, scene.pin_depth(layers, canvas=canvas), (0, 0), canvas)


def box_frame(points: np.ndarray, canvas: tuple[int, int]) -> tuple[int, int, tuple[int, int]]:
    """``(x0, y0, (w, h))``: a frame round ``points`` (n, 2) on the ``canvas`` (its corner
    on the canvas, a pixel of margin), its size rounded up to :data:`FRAME` px (past the
    canvas if need be: :func:`cropped` cuts it off), so that garments drawn one after the
    other share a few sizes and the compositor keeps their targets."""
    P = np.asarray(points, np.float64).reshape(-1, 2)
    if not len(P):
        P = np.zeros((1, 2))
    x0, y0 = (min(max(int(np.floor(v)) - 1, 0), n - 1) for v, n in zip(P.min(axis=0), canvas))
    x1, y1 = (min(max(int(np.ceil(v)) + 1, 1), n) for v, n in zip(P.max(axis=0), canvas))
    return x0, y0, tuple(-(-max(v, 1) // FRAME) * FRAME for v in (x1 - x0, y1 - y0))


def cropped(rgba: np.ndarray, pin_depth: np.ndarray, origin, canvas: tuple[int, int]):
    """A frame drawn with its corner at ``origin`` on the ``canvas`` and its pin depth
    (NaN where nothing shows), cut to the canvas and cropped to where the garment shows:
    ``(rgba, depth grown by a pixel, at)``."""
    (W, H), (x0, y0) = canvas, origin
    rgba[:, W - x0:, 3] = 0  # what falls off the canvas is not the room's (W - x0 >= 1)
    rgba[H - y0:, :, 3] = 0
    x, y, w, h = crop_box(rgba[..., 3])
    return np.ascontiguousarray(rgba[y:y + h, x:x + w]), grow(pin_depth[y:y + h, x:x + w]), (x0 + x, y0 + y)


def garment_spec(scene, path: str) -> tuple[str, str, float]:
    """(name, category, order) of a garment scene read from ``path``: its ``garment``
    section, else the file's stem, ``top`` and 0."""
    spec = scene.data.garment or {}
    return (spec.get("name", os.path.splitext(os.path.basename(path))[0]), spec.get("category", DEFAULT_CATEGORY),
            spec.get("order", 0.0))


def load_garment(path: str, canvas: tuple[int, int], mannequin: str) -> Garment:
    """Render the garment scene at ``path``; refuse one whose canvas is not ``canvas``."""
    scene = puppet.load_scene(path)
    try:
        if tuple(scene.canvas) != tuple(canvas):
            raise SceneError(f"canvas {scene.canvas[0]}x{scene.canvas[1]} differs from the mannequin's "
                             f"{canvas[0]}x{canvas[1]} ({mannequin})", file=scene.file)
        name, category, order = garment_spec(scene, path)
        pose = FIT_POSE if FIT_POSE in scene.data.poses else "rest"
        rgba, depth, at = draw_garment(scene, scene.layers(pose), tuple(canvas))
        return Garment(name=name, category=category, order=order, file=scene.file, rgba=rgba, depth=depth, at=at)
    finally:
        scene.close()


def draw_order(garments: list[Garment]) -> list[Garment]:
    """Back to front: category, then ``order``, then as given."""
    ranked = sorted(enumerate(garments), key=lambda ig: (CATEGORIES.index(ig[1].category), ig[1].order, ig[0]))
    return [g for _, g in ranked]


def load_garments(paths: list[str], canvas: tuple[int, int], mannequin: str, *, load=None,
                  left_out=None) -> list[Garment]:
    """The garments of the scenes ``paths`` in draw order, each read by ``load(path)``
    (default: :func:`load_garment` on the ``canvas``). Two garments of one name are
    refused: SceneError; or, with ``left_out(path, error)``, any garment refused (by its
    name or by ``load``) is given to it and left out."""
    load = load or (lambda path: load_garment(path, canvas, mannequin))
    loaded, names = [], {}
    for path in paths:
        try:
            g = load(path)
            if g.name in names:
                raise SceneError(f"garment name {g.name!r} is also the name of {names[g.name]} "
                                 "(give one a \"garment\": {\"name\": ...})", file=g.file)
        except SceneError as e:
            if left_out is None:
                raise
            left_out(path, e)
            continue
        names[g.name] = g.file
        loaded.append(g)
    return draw_order(loaded)


def load_room(mannequin: str, garments: list[str]) -> Room:
    """Read the mannequin and every garment; refuse two garments of one name."""
    body = load_mannequin(mannequin)
    h, w = body.shape[:2]
    return Room(mannequin=body, garments=load_garments(garments, (w, h), mannequin))


def wear(room: Room, names) -> np.ndarray:
    """The outfit ``names`` on the mannequin, (H, W, 4) straight uint8: each garment
    "over" the picture below it, in draw order (what the page draws)."""
    out = room.mannequin.astype(np.float64) / 255.0
    out[..., :3] *= out[..., 3:]
    for g in room.garments:
        if g.name in names:
            src = g.on_canvas(room.canvas).astype(np.float64) / 255.0
            a = src[..., 3:]
            out = np.concatenate([src[..., :3] * a, a], axis=2) + out * (1.0 - a)
    rgb = np.divide(out[..., :3], out[..., 3:], out=np.zeros_like(out[..., :3]), where=out[..., 3:] > 0)
    return np.rint(np.concatenate([rgb, out[..., 3:]], axis=2) * 255.0).clip(0, 255).astype(np.uint8)
