"""The scene as a document: validated data plus lazily built layers, meshes and solvers."""
from __future__ import annotations

import copy
import json
import os

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import atomic_write, load_rgba
from puppet.scene import build, evaluate as ev, timeline
from puppet.scene.exterior import build_exterior
from puppet.scene.load import load_scene_data
from puppet.scene.model import SceneData


class Document:
    """A loaded scene. Expensive parts (images, meshes, factorisations) are built once,
    on first use, and reused by every pose."""

    def __init__(self, data: SceneData):
        self.data = data
        self._images = None
        self._meshes = None
        self._solver = None
        self._exterior = []
        self._source_size = None
        self._background = None
        #: images this scene owns (not files the user gave): scene-relative name -> (h, w, 4|1) uint8;
        #: written beside the scene by :meth:`save`
        self.owned: dict[str, np.ndarray] = {}

    @classmethod
    def load(cls, path: str):
        """Read, validate and load the pixels of a scene (raises SceneError)."""
        doc = cls(load_scene_data(path))
        doc.images  # images and masks are checked at load time: pins need them
        doc.background()
        doc._check_pins_in_masks()
        return doc

    def background(self):
        """The background: an RGBA colour tuple, or the background image (read once)."""
        bg = self.data.background
        if not isinstance(bg, str):
            return tuple(bg)
        if self._background is None:
            self._background = load_rgba(bg, scene_file=self.file, json_path="background")
        return self._background

    # -- built parts -------------------------------------------------------------
    @property
    def file(self) -> str:
        return self.data.file

    @property
    def images(self) -> list[build.LayerImage]:
        if self._images is None:
            self._images = build.build_images(self.data)
        return self._images

    @property
    def canvas(self) -> tuple[int, int]:
        """Output size (W, H): ``canvas``, else the source's size, else the first layer image's."""
        if self.data.canvas is not None:
            return self.data.canvas
        if self.data.source is not None:
            src = next((im for im in self.images if im.from_source), None)
            if src is None:  # no layer takes its pixels from the source: read its size once
                if self._source_size is None:
                    from PIL import Image

                    with Image.open(self.data.source) as im:
                        self._source_size = im.size
                return self._source_size
            h, w = src.rgba.shape[:2]
            return (w, h)
        h, w = self.images[0].rgba.shape[:2]
        return (w, h)

    @property
    def rank(self) -> list[int]:
        return build.stacking(self.data)

    def _build_meshes(self):
        if self._meshes is None:
            meshes = build.build_meshes(self.data, self.images)
            self._exterior, _ = build_exterior(self.data, self.images, meshes[2])
            self._solver = ev.Solver(self.data, meshes[2], self._exterior)
            self._meshes = meshes
        return self._meshes

    @property
    def groups(self) -> list[build.Group]:
        return self._build_meshes()[2]

    def _check_pins_in_masks(self):
        index = {L.name: L.index for L in self.data.layers}
        for i, p in enumerate(self.data.pins):
            if p.kind == "interior" and not self.images[index[p.layer]].contains(p.at):
                raise SceneError(f"pin {p.name!r} at ({p.at[0]:g}, {p.at[1]:g}) is outside the mask of layer "
                                 f"{p.layer!r}", file=self.file, path=f"pins[{i}].at")

    # -- poses -------------------------------------------------------------------
    def pose_names(self) -> list[str]:
        return ["rest"] + list(self.data.poses)

    def state(self, pose: str | None = None, time: float | None = None) -> ev.PinState:
        """Pin targets for a named pose or a time on the animation (default: rest)."""
        self._build_meshes()
        if pose is not None and time is not None:
            raise SceneError("give a pose or a time, not both", file=self.file)
        if time is not None:
            anim = self.data.animation
            if anim is None:
                raise SceneError("the scene has no animation, so --time cannot be used", file=self.file)
            if not np.isfinite(time) or time < 0:
                raise SceneError(f"time must be a number >= 0, got {time}", file=self.file)
            a, b, t = timeline.segment_at(anim, float(time))
            ext_rest = np.concatenate([ge.rest for ge in self._exterior]) if self._exterior else np.zeros((0, 2))
            return ev.blend(self._named(a), self._named(b), t, ext_rest)
        return self._named(pose or "rest")

    def _named(self, pose: str) -> ev.PinState:
        if pose != "rest" and pose not in self.data.poses:
            raise SceneError(f"no pose named {pose!r} (poses: {', '.join(self.pose_names())})", file=self.file)
        self._build_meshes()
        if pose == "rest":
            return ev.rest_state(self.data, self._exterior)
        return ev.pose_state(self.data, self._exterior, self.data.poses[pose])

    def layers(self, pose: str | None = None, time: float | None = None) -> list[ev.LayerResult]:
        """Deformed meshes and depths of every layer in a pose or at a time."""
        meshes, pin_vertex, groups = self._build_meshes()
        return ev.evaluate(self.data, meshes, pin_vertex, groups, self._solver, self.rank,
                           self.state(pose, time))

    def mesh(self, pose: str | None = None, time: float | None = None) -> dict:
        """The meshes as data, as ``puppet mesh`` writes them."""
        res = self.layers(pose, time)
        out = {"puppet": 1, "canvas": list(self.canvas)}
        out["pose"] = pose if pose is not None else ("rest" if time is None else None)
        if time is not None:
            out["time"] = float(time)
        out["layers"] = [{
            "name": r.name, "group": r.group, "order": r.order,
            "rest": r.rest.tolist(), "deformed": r.deformed.tolist(), "triangles": r.triangles.tolist(),
            "depth": r.depth.tolist(), "pins": {k: int(v) for k, v in r.pins.items()}, "exterior": r.exterior,
        } for r in res]
        return out

    def summary(self) -> str:
        """A few lines on the scene: layers, groups, vertices, triangles, and what is not applied yet."""
        meshes, _, groups = self._build_meshes()
        d = self.data
        W, H = self.canvas
        lines = [f"{self.file}: canvas {W}x{H}, {len(d.layers)} layer(s), {len(groups)} group(s), "
                 f"{len(d.pins)} pin(s), {len(d.poses)} pose(s)"
                 + (f", animation {timeline.duration(d.animation):g} s at {d.animation.fps:g} fps"
                    if d.animation else "")]
        for k, (L, m) in enumerate(zip(d.layers, meshes)):
            gi = next(i for i, g in enumerate(groups) if k in g.layers)
            lines.append(f"  layer {L.name!r}: order {self.rank[k]}, group {gi}, {len(m.V)} vertices, "
                         f"{len(m.F)} triangles")
        for gi, g in enumerate(groups):
            lines.append(f"  group {gi}: {len(g.layers)} layer(s), {len(g.mesh.V)} vertices, "
                         f"{len(g.mesh.F)} triangles, {len(g.pins)} pin(s)")
        lines += [f"  note: {n}" for n in self.not_applied()]
        return "\n".join(lines)

    def not_applied(self) -> list[str]:
        """Things the scene asks for that this version accepts but does not apply."""
        d = self.data
        notes = []
        if d.deformer.method != "arap" and any(abs(t.angle) > 0 for pose in d.poses.values() for t in pose.values()):
            notes.append(f"pin angles are applied by the 'arap' method only, not by {d.deformer.method!r}")
        if d.bones and d.deformer.method != "mls-skeleton":
            notes.append("bones are used by the 'mls-skeleton' method only")
        return notes

    def to_json(self, folder: str) -> dict:
        """The scene as JSON with every file path relative to ``folder``."""
        raw = copy.deepcopy(self.data.raw)
        src = os.path.dirname(self.file)

        def rel(path: str) -> str:
            if path in self.owned:
                return path
            return os.path.relpath(os.path.normpath(os.path.join(src, path)), folder).replace(os.sep, "/")

        for key in ("source", "background"):
            if isinstance(raw.get(key), str):
                raw[key] = rel(raw[key])
        for L in raw["layers"]:
            if "image" in L:
                L["image"] = rel(L["image"])
            if isinstance(L.get("mask"), dict) and "file" in L["mask"]:
                L["mask"]["file"] = rel(L["mask"]["file"])
        return raw

    def save(self, path: str) -> None:
        """Write the scene (and the images it owns, beside it), each file atomically.

        File paths inside the scene are rewritten relative to the new location, so the
        saved scene loads and renders the same pixels wherever it is written.
        """
        from puppet.imaging.io import save_png

        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise SceneError(f"cannot save: folder {folder!r} does not exist", file=path)
        text = json.dumps(self.to_json(folder), indent=1)
        for name, img in self.owned.items():
            save_png(os.path.join(folder, name), img)

        def write(tmp):
            with open(tmp, "w") as f:
                f.write(text + "\n")
        atomic_write(path, write)

    def write_mesh(self, path: str, pose: str | None = None, time: float | None = None) -> None:
        text = json.dumps(self.mesh(pose, time), separators=(",", ":"))

        def write(tmp):
            with open(tmp, "w") as f:
                f.write(text)
        atomic_write(path, write)
