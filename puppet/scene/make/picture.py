"""``puppet init``: a one-layer scene and its mask from a picture, for users who script.

The scene takes the picture as its ``source`` (the template its layer takes pixels
from), has one layer whose mask is a PNG written beside the scene (``SCENE-mask.png``,
referenced as ``{"file": ...}``; paths relative to the scene's folder), and, with
``pins="auto"``, pins at the end points and junctions of the mask's skeleton
(:func:`puppet.imaging.skeleton.auto_pins`), so a silhouette can be posed at once.

Both files are outputs: neither may be a file the scene reads, and the scene is
validated and meshed (with the mask as written) before either is put in place.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

import numpy as np

from puppet.errors import SceneError
from puppet.imaging import masks as mk
from puppet.imaging.io import load_rgba
from puppet.imaging.skeleton import auto_pins
from puppet.output import Staged, check_file, commit_all
from puppet.scene.document.core import Document
from puppet.scene.format.write import scene_text
from puppet.scene.make.art import scene_paths

#: How the mask is made: the scene format's default rule, alpha, a luminance threshold, GrabCut.
MASK_RULES = ("default", "alpha", "threshold", "grabcut")


@dataclass
class InitResult:
    """What :func:`init_scene` wrote: paths, the mask's size in pixels and components, pins."""

    scene: str
    mask_file: str
    layer: str
    size: tuple[int, int]
    rule: str
    area: int
    components: int
    pins: dict[str, list[float]] = field(default_factory=dict)

    def summary(self) -> str:
        """One line for the command line."""
        w, h = self.size
        return (f"{self.scene}: {w}x{h}, layer {self.layer!r}, mask ({self.rule}) {self.area} px "
                f"({100.0 * self.area / (w * h):.1f} %), {self.components} component(s), "
                f"{len(self.pins)} pin(s); mask written to {self.mask_file}")


def mask_path_for(scene: str) -> str:
    """Where the mask of a scene written to ``scene`` goes: ``SCENE-mask.png`` beside it."""
    return os.path.splitext(scene)[0] + "-mask.png"


def layer_name(image: str) -> str:
    """A readable layer name from a picture's file name (``horse.png`` -> ``horse``)."""
    stem = os.path.splitext(os.path.basename(image))[0]
    return re.sub(r"[^A-Za-z0-9_-]+", "_", stem).strip("_") or "layer"


def make_mask(rgba: np.ndarray, rule: str = "default", *, threshold: float | None = None,
              rect=None) -> tuple[np.ndarray, str]:
    """The layer mask of an (h, w, 4) uint8 picture and a short description of the rule.

    ``default``: alpha > 0 when any pixel is not opaque, else luminance < 250 (the scene
    format's default mask); ``alpha``; ``threshold`` (luminance < ``threshold``);
    ``grabcut`` (GrabCut inside ``rect`` = [x, y, w, h]). Fully transparent pixels are
    never in the mask. Returns ((h, w) bool, description).
    """
    if rule == "default":
        if mk.has_transparency(rgba):
            return mk.alpha_mask(rgba), "alpha"
        return mk.threshold_mask(rgba, 250.0), "threshold 250"
    if rule == "alpha":
        return mk.alpha_mask(rgba), "alpha"
    if rule == "threshold":
        return mk.threshold_mask(rgba, float(threshold)), f"threshold {float(threshold):g}"
    if rule == "grabcut":
        x, y, w, h = (float(v) for v in rect)
        H, W = rgba.shape[:2]
        if x >= W or y >= H or x + w <= 0 or y + h <= 0:
            raise SceneError(f"--grabcut {x:g},{y:g},{w:g},{h:g}: the rectangle is outside the {W}x{H} picture")
        return mk.grabcut_mask(rgba, (x, y, w, h)) & (rgba[..., 3] > 0), f"grabcut {x:g},{y:g},{w:g},{h:g}"
    raise ValueError(f"unknown mask rule {rule!r}")


def count_components(mask: np.ndarray) -> int:
    """Connected components (8-connected) of a bool mask."""
    import cv2

    return int(cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)[0]) - 1


def scene_doc(image: str, mask_file: str, layer: str, pins, scene: str | None) -> dict:
    """The scene JSON; paths as written in the scene file ``scene``
    (:func:`~puppet.scene.make.art.scene_paths`: relative where that loads through a
    symlinked scene too), None: kept as given."""
    rel = (lambda p: p) if scene is None else scene_paths(scene)

    doc = {"puppet": 1, "source": rel(image),
           "layers": [{"name": layer, "mask": {"file": rel(mask_file)}}]}
    if pins:
        doc["pins"] = [{"name": p.name, "layer": layer, "at": list(p.at)} for p in pins]
    return doc


def init_scene(image: str, scene: str, *, rule: str = "default", threshold: float | None = None,
               rect=None, pins: str = "none", max_pins: int = 16) -> InitResult:
    """Write a one-layer scene over ``image`` to ``scene`` and its mask beside it.

    Parameters
    ----------
    image : the picture (any format puppet reads).
    scene : the scene file to write (``.json``); the mask goes to :func:`mask_path_for`.
    rule, threshold, rect : how the mask is made (:func:`make_mask`).
    pins : ``"none"`` or ``"auto"`` (skeleton end points and junctions, at most ``max_pins``).

    Returns
    -------
    InitResult

    Raises
    ------
    SceneError
        Unreadable picture, an empty mask, an output that is an input or cannot be
        written (nothing is written then).
    """
    shown = scene
    image = os.path.abspath(image)
    scene = os.path.abspath(scene)
    mask_file = mask_path_for(scene)
    inputs = [(image, "the picture")]
    check_file(scene, inputs=inputs, probe=True)
    check_file(mask_file, inputs=inputs, probe=True, follow=False)  # a name puppet chose: never through a link
    rgba = load_rgba(image)
    mask, how = make_mask(rgba, rule, threshold=threshold, rect=rect)
    if not mask.any():
        raise SceneError(f"the mask ({how}) selects no pixels of the picture; try another "
                         "--threshold, --alpha or --grabcut", file=image)
    found = []
    if pins == "auto":
        found = auto_pins(mask, max_pins=max_pins)
    name = layer_name(image)
    text = scene_text(scene_doc(image, mask_file, name, found, scene))

    def write_mask(tmp: str) -> None:
        from PIL import Image

        Image.fromarray(mask.astype(np.uint8) * 255, mode="L").save(tmp, format="PNG")
        _validate(scene_doc(image, tmp, name, found, None), scene)

    def write_scene(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)

    staged = [Staged(mask_file, write_mask, inputs=inputs, follow=False)]
    try:
        staged.append(Staged(scene, write_scene, inputs=inputs + [(mask_file, "the mask")]))
    except BaseException:
        staged[0].discard()
        raise
    commit_all(staged)  # both written in full: two renames
    h, w = mask.shape
    return InitResult(scene=shown, mask_file=mask_path_for(shown), layer=name, size=(w, h), rule=how,
                      area=int(mask.sum()), components=count_components(mask),
                      pins={p.name: list(p.at) for p in found})


def _validate(doc: dict, scene: str) -> None:
    """Load and mesh the scene as it will be (pins placed in the mesh), or raise SceneError."""
    d = Document(doc, scene)
    d.built  # noqa: B018  (builds images, masks and meshes: pins outside the mask or the mesh fail here)
