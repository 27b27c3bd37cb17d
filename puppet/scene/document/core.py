"""The scene as an editable document: the scene JSON as it is now (the model), with the
validated :class:`SceneData` and the built :class:`~puppet.scene.rig.core.Built` derived from
it, change events, and an undo history.

The document JSON is never changed in place: an edit builds a changed copy, validates
it (the same checks as loading a file, then the meshes it touches), and only then
replaces the old one, so a rejected edit leaves nothing half done and every history
snapshot stays as it was. File paths inside it are kept absolute and written relative
to the scene's folder by :meth:`Document.save`.
"""
from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import image_size, load_rgba
from puppet.output import write_text
from puppet.scene.document.deform_edits import DeformEdits
from puppet.scene.document.edits import Edits
from puppet.scene.document.files import PendingFiles
from puppet.scene.document.history import Event, Events, History, Step
from puppet.scene.document.key_edits import KeyEdits
from puppet.scene.drag.session import DragSession, drag_solver
from puppet.scene.format import args as ck
from puppet.scene.format.extensions import UNDERLAY_DEFAULTS
from puppet.scene.format.inputs import input_files
from puppet.scene.format.load import Ctx, _pose, parse_scene, read_json
from puppet.scene.format.model import SceneData, Target
from puppet.scene.format.write import map_paths, relative_to, scene_text
from puppet.scene.rig import disk
from puppet.scene.rig.cache import file_stamp, fingerprint
from puppet.scene.rig.core import Built, LayerResult, Rig
from puppet.scene.time import evaluate as ev
from puppet.scene.time import timeline
from puppet.scene.time.tracks import Tracks, build_tracks, state_at

PoseLike = str | dict | None


class Document(Edits, KeyEdits, DeformEdits):
    """An editable scene. Load with :meth:`load`; pose with :meth:`layers` / :meth:`mesh`."""

    def __init__(self, doc: dict, file: str):
        self.file = os.path.abspath(file)
        self.events = Events()
        self.history = History()
        self.rig = Rig()
        self._doc: dict = {}
        self._active = "rest"
        self._data: SceneData | None = None
        self._built: Built | None = None
        self._tracks = None
        #: pixels painted in the app, kept as PNGs until the scene is saved
        self.pending = PendingFiles()
        self._set(doc, "rest", build=False)

    @classmethod
    @ck.checked(path=ck.path)
    def load(cls, path: str):
        """Read and validate a scene file (raises SceneError)."""
        path = os.path.abspath(path)
        folder = os.path.dirname(path)
        raw = read_json(path)
        if isinstance(raw, dict):  # paths absolute inside the model; parse_scene reports bad ones
            raw = map_paths(raw, lambda p: os.path.normpath(os.path.join(folder, p)))
        doc = cls(raw, path)
        doc.rig.memo.disk = disk.beside(path)  # built parts kept beside the scene file
        return doc

    @classmethod
    @ck.checked(image=ck.path, layer=ck.text, scene_file=ck.optional(ck.path))
    def from_image(cls, image: str, *, layer: str = "layer1", scene_file: str | None = None):
        """A new one-layer scene over a picture: the picture is the scene's ``source``
        (the template that layers take pixels from) and the first layer takes all of it
        with the default mask (alpha when the picture has transparency, else non-white).
        Not written anywhere until :meth:`save`; ``scene_file`` (default: the picture's
        name with ``.json``) is where it would be saved."""
        image = os.path.abspath(image)
        load_rgba(image)  # a missing or bad picture is refused before anything is made
        doc = {"puppet": 1, "source": image, "layers": [{"name": layer}]}
        return cls(doc, scene_file or os.path.splitext(image)[0] + ".json")

    # -- the model and what is derived from it -----------------------------------
    @property
    def data(self) -> SceneData:
        """The validated scene as it is now."""
        return self._data

    @property
    def built(self) -> Built:
        """Images, meshes, groups and solver precomputations of the scene as it is now."""
        if self._built is None:
            self._built = self.rig.build(self._data)
        return self._built

    @ck.checked()
    def to_dict(self) -> dict:
        """The scene JSON as it is now (paths absolute), a copy."""
        return json.loads(json.dumps(self._doc))

    def _set(self, doc: dict, active: str, *, build: bool = True) -> None:
        """Make ``doc`` the model after validating it; on SceneError nothing changes."""
        data = parse_scene(doc, self.file)
        if active != "rest" and active not in data.poses:
            active = "rest"
        built = self.rig.build(data) if build else None
        self._doc, self._active, self._data, self._built = doc, active, data, built

    def _edit(self, event: Event, mutate: Callable[[dict], str | None]) -> bool:
        """Apply ``mutate`` to a copy of the document (it may return a new active pose
        name), validate, record one undo step and emit ``event``. False if nothing changed."""
        doc = json.loads(json.dumps(self._doc))
        active = mutate(doc) or self._active
        if doc == self._doc and active == self._active:
            return False
        before = (self._doc, self._active)
        self._set(doc, active)
        if not self.history.in_block:
            self.history.push(Step(event.label or event.type, before, (self._doc, self._active), event))
        self.events.emit(event)
        return True

    @contextlib.contextmanager
    @ck.checked(label=ck.text)
    def block(self, label: str):
        """Record every edit made inside as one undo step (a whole drag, a paste)."""
        self.history.open((self._doc, self._active), label)
        try:
            yield self
        finally:
            self.history.close((self._doc, self._active))

    @ck.checked()
    def undo(self) -> bool:
        """Go back one step; False when there is nothing to undo."""
        return self._travel("undo")

    @ck.checked()
    def redo(self) -> bool:
        """Redo the last undone step; False when there is nothing to redo."""
        return self._travel("redo")

    def _travel(self, way: str) -> bool:
        """Move one step from the ``way`` stack (``"undo"`` or ``"redo"``) to the other,
        setting the state before (undo) or after (redo) it, and say so."""
        undo = way == "undo"
        src, dst = ((self.history.undo_stack, self.history.redo_stack) if undo
                    else (self.history.redo_stack, self.history.undo_stack))
        if not (self.history.can_undo() if undo else self.history.can_redo()):
            return False
        step = src.pop()
        self._set(*(step.before if undo else step.after))
        dst.append(step)
        self.events.emit(Event(way, level="mesh", label=step.label))
        return True

    # -- drawing facts -----------------------------------------------------------
    @ck.checked()
    def background(self):
        """The background: an RGBA colour tuple, or the background image (read once per file)."""
        bg = self.data.background
        if not isinstance(bg, str):
            return tuple(bg)
        return self.rig.memo.get("pixels", fingerprint("background", file_stamp(bg)),
                                 lambda: load_rgba(bg, scene_file=self.file, json_path="background"))

    @property
    def underlay(self) -> dict | None:
        """The app's reference picture: ``{"image": abs path, "opacity", "offset", "scale"}`` or None."""
        u = self._doc.get("app", {}).get("underlay")
        if u is None:
            return None
        return {**UNDERLAY_DEFAULTS, **u}

    @ck.checked()
    def underlay_image(self):
        """The underlay picture as (h, w, 4) uint8 RGBA (read once per file), or None."""
        u = self.underlay
        if u is None:
            return None
        return self.rig.memo.get("pixels", fingerprint("underlay", file_stamp(u["image"])),
                                 lambda: load_rgba(u["image"], scene_file=self.file, json_path="app.underlay.image"))

    @property
    def images(self):
        return self.built.images

    @property
    def canvas(self) -> tuple[int, int]:
        """Output size (W, H): ``canvas``, else the source's size, else the first layer image's."""
        d = self.data
        if d.canvas is not None:
            return d.canvas
        if d.source is not None:
            def size():  # from the header, checked like every image (a FIFO must not hang)
                return image_size(d.source, scene_file=self.file, json_path="source")
            return tuple(self.rig.memo.get("pixels", fingerprint("size", file_stamp(d.source)), size))
        h, w = self.built.images[0].rgba.shape[:2]
        return (w, h)

    @property
    def rank(self) -> list[int]:
        return self.built.rank

    @property
    def groups(self):
        return self.built.groups

    # -- poses -------------------------------------------------------------------
    @property
    def active_pose(self) -> str:
        """The pose that :meth:`layers` and ``render()`` show with no argument."""
        return self._active

    @ck.checked()
    def pose_names(self) -> list[str]:
        return ["rest"] + list(self.data.poses)

    @ck.checked(pose=ck.pose_like, where=ck.text)
    def parse_pose(self, pose: dict, where: str = "pose") -> dict[str, Target]:
        """An ad-hoc pose (same form as a pose in the file) checked like one."""
        d = self.data
        names = {L.name: L.index for L in d.layers}
        return _pose(Ctx(self.file), pose, where, {p.name: i for i, p in enumerate(d.pins)}, d.layers, names)

    @ck.checked(pose=ck.pose_like, time=ck.optional(ck.TIME))
    def state(self, pose: PoseLike = None, time: float | None = None) -> ev.PinState:
        """Pin targets for a pose (a name, an ad-hoc dict, or None for the active pose) or a time."""
        if pose is not None and time is not None:
            raise SceneError("give a pose or a time, not both", file=self.file)
        built = self.built
        if time is not None:
            time = self._check_time(time)
            return state_at(self.tracks(), time)
        if isinstance(pose, dict):
            return ev.pose_state(self.data, built.exterior, self.parse_pose(pose))
        if pose is not None and not isinstance(pose, str):
            raise SceneError(f"a pose is a name or a dict of pin targets, not {type(pose).__name__}",
                             file=self.file)
        return self._named(self._active if pose is None else pose)

    def _check_time(self, time) -> float:
        if self.data.animation is None:
            raise SceneError("the scene has no animation, so --time cannot be used", file=self.file)
        if not np.isfinite(time) or time < 0:
            raise SceneError(f"time must be a number >= 0, got {time}", file=self.file)
        return float(time)

    @ck.checked()
    def tracks(self) -> Tracks:
        """The animation's keys as per-pin tracks (built once per version of the scene)."""
        built = self.built
        if self._tracks is None or self._tracks[0] is not built:
            self._tracks = (built, build_tracks(self.data, built.exterior))
        return self._tracks[1]

    def _named(self, pose: str) -> ev.PinState:
        if pose != "rest" and pose not in self.data.poses:
            raise SceneError(f"no pose named {pose!r} (poses: {', '.join(self.pose_names())})", file=self.file)
        if pose == "rest":
            return ev.rest_state(self.data, self.built.exterior)
        return ev.pose_state(self.data, self.built.exterior, self.data.poses[pose])

    @ck.checked(pose=ck.pose_like, time=ck.optional(ck.TIME))
    def layers(self, pose: PoseLike = None, time: float | None = None) -> list[LayerResult]:
        """Deformed meshes and depths of every layer in a pose or at a time (the
        animation's in-between: see :mod:`puppet.scene.time.inbetween`)."""
        if time is not None and pose is None:
            from puppet.scene.time.inbetween import layers_at  # lazy: in-betweens (and their solver) for times only

            time = self._check_time(time)
            return layers_at(self.rig, self.built, self.tracks(), time)
        return self.rig.evaluate(self.built, self.state(pose, time))

    @ck.checked(names=ck.texts, time=ck.optional(ck.TIME), record=ck.flag, iterations=ck.ITERATIONS,
                solver=ck.optional(drag_solver))
    def drag(self, names, time: float | None = None, *, record: bool = False, iterations: int = 4, solver=None):
        """Start a drag of pins ``names`` (one name or a list): in the active pose, keyed
        at ``time``, or a recording from ``time``; previews solved in ``solver`` (a
        :class:`~puppet.scene.drag.process.DragProcess`) when given (see
        :class:`puppet.scene.drag.session.DragSession`)."""
        return DragSession(self, names, time, record=record, iterations=iterations, solver=solver)

    @ck.checked(pose=ck.pose_like, time=ck.optional(ck.TIME))
    def mesh(self, pose: PoseLike = None, time: float | None = None) -> dict:
        """The meshes as data, as ``puppet mesh`` writes them."""
        res = self.layers(pose, time)
        out = {"puppet": 1, "canvas": list(self.canvas)}
        if time is not None:
            out["pose"] = None
            out["time"] = float(time)
        else:
            out["pose"] = pose if isinstance(pose, str) else (self._active if pose is None else None)
        out["layers"] = [{
            "name": r.name, "group": r.group, "order": r.order,
            "rest": r.rest.tolist(), "deformed": r.deformed.tolist(), "triangles": r.triangles.tolist(),
            "depth": r.depth.tolist(), "pins": {k: int(v) for k, v in r.pins.items()}, "exterior": r.exterior,
        } for r in res]
        return out

    @ck.checked()
    def summary(self) -> str:
        """A few lines on the scene: layers, groups, vertices, triangles, and what is not applied yet."""
        built, d = self.built, self.data
        self.background()  # a bad background image is reported by `puppet check` too
        W, H = self.canvas
        lines = [f"{self.file}: canvas {W}x{H}, {len(d.layers)} layer(s), {len(built.groups)} group(s), "
                 f"{len(d.pins)} pin(s), {len(d.poses)} pose(s)"
                 + (f", animation {timeline.duration(d.animation):g} s at {d.animation.fps:g} fps"
                    if d.animation else "")]
        for k, (L, m) in enumerate(zip(d.layers, built.meshes)):
            gi = next(i for i, g in enumerate(built.groups) if k in g.layers)
            extra = "".join([f", mode {L.mode or d.deformer.mode}" if (L.mode or d.deformer.mode) != "rigid" else "",
                             ", painted stiffness" if L.stiffness else ""])
            lines.append(f"  layer {L.name!r}: order {built.rank[k]}, group {gi}, {len(m.V)} vertices, "
                         f"{len(m.F)} triangles{extra}")
        for gi, g in enumerate(built.groups):
            extra = "".join([f", {len(g.hinges)} hinge(s)" if len(g.hinges) else "",
                             f", {len(g.couple)} spring(s)" if len(g.couple) else ""])
            lines.append(f"  group {gi}: {len(g.layers)} layer(s), {len(g.mesh.V)} vertices, "
                         f"{len(g.mesh.F)} triangles, {len(g.pins)} pin(s){extra}")
        lines += [f"  note: {n}" for n in self.not_applied()]
        return "\n".join(lines)

    @ck.checked()
    def not_applied(self) -> list[str]:
        """Things the scene asks for that this version accepts but does not apply."""
        d = self.data
        notes = []
        if d.deformer.method != "arap" and any(abs(t.angle) > 0 for pose in d.poses.values() for t in pose.values()):
            notes.append(f"pin angles are applied by the 'arap' method only, not by {d.deformer.method!r}")
        if d.bones and d.deformer.method != "mls-skeleton":
            notes.append("bones are used by the 'mls-skeleton' method only")
        if d.deformer.method != "arap" and (any(L.stiffness for L in d.layers) or any(p.kind == "starch" for p in d.pins)):
            notes.append(f"stiffness and starch pins are applied by the 'arap' method only, not by {d.deformer.method!r}")
        if d.deformer.method not in ("arap", "mls") and any(k.strength < 1 for k in d.links):
            notes.append(f"link strength below 1 is applied by 'arap' and 'mls' only; {d.deformer.method!r} leaves "
                         "such links untied")
        if d.chains and d.animation is None:
            notes.append("physics chains swing in an animation only, and the scene has none")
        return notes + list(self.built.notes)

    # -- files -------------------------------------------------------------------
    @ck.checked(folder=ck.path)
    def to_json(self, folder: str) -> dict:
        """The scene JSON as it is now, with every file path relative to ``folder``."""
        return map_paths(self.to_dict(), relative_to(folder))

    @ck.checked(path=ck.path, copy=ck.flag, follow=ck.flag)
    def save(self, path: str, *, copy: bool = False, follow: bool = True) -> None:
        """Write the scene as it is now, atomically; file paths inside are written relative
        to the new location, so the saved scene loads and renders the same pixels.

        Pixels painted since loading (:meth:`set_mask_pixels`, :meth:`set_layer_pixels`)
        are written beside the scene, in ``SCENE.files/``, first; the scene then reads them
        there, unless ``copy`` (an autosave: the next save writes them beside its own
        scene again). Goes through :mod:`puppet.output`: an image the scene reads is never
        overwritten (the scene file itself may be), a symlink at ``path`` is written
        through only with ``follow``, and a write failure raises an OutputError and leaves
        nothing of this save behind (no new ``SCENE.files/``)."""
        inputs = input_files(self.data, scene_file=False)
        used: set[str] = set()
        map_paths(self._doc, lambda p: used.add(p) or p)
        moved, undo = self.pending.publish({p for p in used if self.pending.owns(p)}, path, inputs)
        doc = map_paths(self._with_cage_points(), lambda p: moved.get(p, p))
        text = scene_text(map_paths(doc, relative_to(os.path.dirname(os.path.abspath(path)))))
        try:
            write_text(path, text, inputs=inputs, follow=follow)
        except BaseException:
            undo()
            raise
        if moved and not copy:  # from now on the scene reads the saved copies (same pixels, same keys)
            self._set(doc, self._active)

    def _with_cage_points(self) -> dict:
        """The scene JSON with the points of each automatic cage written beside its
        ``auto`` (the cage its ``LAYER:cageN`` handles were posed on); itself where none
        lacks them."""
        built, doc = None, self._doc
        for k, L in enumerate(self._doc["layers"]):
            cage = L.get("cage")
            if isinstance(cage, dict) and "auto" in cage and "points" not in cage:
                built = built or self.built
                rest = next(c.rest for c in built.cages if c is not None and c.layer == k)
                if doc is self._doc:
                    doc = dict(doc, layers=list(doc["layers"]))
                doc["layers"][k] = dict(L, cage=dict(cage, points=rest.tolist()))
        return doc

    @ck.checked(folder=ck.path)
    def adopt_files(self, folder: str) -> None:
        """Own again the pixels this scene reads from ``folder`` (an autosave's
        ``NAME.autosave.files/``), so that saving writes them into ``SCENE.files/``."""
        folder = os.path.realpath(folder)
        used: set[str] = set()
        map_paths(self._doc, lambda p: used.add(p) or p)
        with self.pending.staged():  # copies are removed again when the scene refuses them
            mine = {p: self.pending.adopt(p) for p in used if os.path.dirname(os.path.realpath(p)) == folder}
            if mine:
                self._set(map_paths(self._doc, lambda p: mine.get(p, p)), self._active)

    @ck.checked(path=ck.path, pose=ck.pose_like, time=ck.optional(ck.TIME))
    def write_mesh(self, path: str, pose: PoseLike = None, time: float | None = None) -> None:
        """Write :meth:`mesh` as JSON (``puppet mesh``), through :mod:`puppet.output`."""
        text = json.dumps(self.mesh(pose, time), separators=(",", ":"))
        write_text(path, text, inputs=input_files(self.data))
