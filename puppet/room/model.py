"""The dressing room's content: the mannequin and the garments rendered on its canvas.

A garment is a scene rendered at its pose ``fit`` (else at rest) over a clear background,
with its per-pixel depth (:mod:`puppet.room.depth`). Garments are drawn in
:func:`draw_order`: by category (:data:`~puppet.scene.format.garment.CATEGORIES`, back
to front), then ``order``, then the order they were given in.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

import puppet
from puppet.errors import SceneError
from puppet.imaging.io import load_rgba
from puppet.room.depth import front_depth, layer_depth
from puppet.scene.format.garment import CATEGORIES, DEFAULT_CATEGORY

#: The pose a garment is shown in when its scene has one.
FIT_POSE = "fit"
CLEAR = (0, 0, 0, 0)


@dataclass(frozen=True)
class Garment:
    """One garment: ``rgba`` (H, W, 4) straight uint8 on the mannequin's canvas, clear
    around it; ``depth`` (H, W) float64, NaN where it does not show."""

    name: str
    category: str
    order: float
    file: str
    rgba: np.ndarray
    depth: np.ndarray


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


def load_garment(path: str, canvas: tuple[int, int], mannequin: str) -> Garment:
    """Render the garment scene at ``path``; refuse one whose canvas is not ``canvas``."""
    scene = puppet.load_scene(path)
    try:
        if tuple(scene.canvas) != tuple(canvas):
            raise SceneError(f"canvas {scene.canvas[0]}x{scene.canvas[1]} differs from the mannequin's "
                             f"{canvas[0]}x{canvas[1]} ({mannequin})", file=scene.file)
        spec = scene.data.garment or {}
        name = spec.get("name", os.path.splitext(os.path.basename(path))[0])
        pose = FIT_POSE if FIT_POSE in scene.data.poses else "rest"
        layers = scene.layers(pose)
        rgba = scene.draw_layers(layers, background=CLEAR)
        images = scene.built.images
        shown = [k for k, L in enumerate(scene.data.layers) if L.visible]
        pins = [layer_depth(layers[k].deformed, layers[k].rest, layers[k].triangles,
                            layers[k].depth - layers[k].order, *images[k].drawn, canvas) for k in shown]
        depth = front_depth(pins or [np.full(rgba.shape[:2], np.nan)], [layers[k].order for k in shown] or [0])
        return Garment(name=name, category=spec.get("category", DEFAULT_CATEGORY), order=spec.get("order", 0.0),
                       file=scene.file, rgba=rgba, depth=depth)
    finally:
        scene.close()


def draw_order(garments: list[Garment]) -> list[Garment]:
    """Back to front: category, then ``order``, then as given."""
    ranked = sorted(enumerate(garments), key=lambda ig: (CATEGORIES.index(ig[1].category), ig[1].order, ig[0]))
    return [g for _, g in ranked]


def load_room(mannequin: str, garments: list[str]) -> Room:
    """Read the mannequin and every garment; refuse two garments of one name."""
    body = load_mannequin(mannequin)
    h, w = body.shape[:2]
    loaded, names = [], {}
    for path in garments:
        g = load_garment(path, (w, h), mannequin)
        if g.name in names:
            raise SceneError(f"garment name {g.name!r} is also the name of {names[g.name]} "
                             "(give one a \"garment\": {\"name\": ...})", file=g.file)
        names[g.name] = g.file
        loaded.append(g)
    return Room(mannequin=body, garments=draw_order(loaded))


def wear(room: Room, names) -> np.ndarray:
    """The outfit ``names`` on the mannequin, (H, W, 4) straight uint8: each garment
    "over" the picture below it, in draw order (what the page draws)."""
    out = room.mannequin.astype(np.float64) / 255.0
    out[..., :3] *= out[..., 3:]
    for g in room.garments:
        if g.name in names:
            src = g.rgba.astype(np.float64) / 255.0
            a = src[..., 3:]
            out = np.concatenate([src[..., :3] * a, a], axis=2) + out * (1.0 - a)
    rgb = np.divide(out[..., :3], out[..., 3:], out=np.zeros_like(out[..., :3]), where=out[..., 3:] > 0)
    return np.rint(np.concatenate([rgb, out[..., 3:]], axis=2) * 255.0).clip(0, 255).astype(np.uint8)
