"""What the scene session publishes and keeps: the immutable :class:`Snapshot` the window
draws, the :class:`Shown` value (what the canvas shows), status :class:`Message` s, and
the :class:`FrameCache` of solved animation frames."""
from __future__ import annotations

import collections
import time
from dataclasses import dataclass, field
from typing import Any

from puppet.app.model import onion
from puppet.errors import SceneError

#: solved frames kept per scene state (LayerResults are a few arrays per layer: ~0.25 MB
#: a frame for the T-rex's 9 800 vertices)
FRAME_CACHE = 400


@dataclass(frozen=True)
class Shown:
    """What the canvas shows: the rest pose (``rest``, Pin mode), else the animation at
    ``time`` when set and the scene has keys, else the active pose; ``onion``: the onion
    skin settings as sorted items (None: off)."""

    rest: bool = False
    time: float | None = None
    onion: tuple | None = None


@dataclass(frozen=True)
class Snapshot:
    """What the window shows, as published by the scene thread after a job.

    ``layers`` are the shown pose's :class:`~puppet.scene.rig.core.LayerResult` (rest in Pin
    mode, the active pose in Pose mode, the animation at ``time``, or a drag preview when
    ``preview``)."""

    version: int
    file: str | None = None
    data: Any = None
    active: str = "rest"
    shown: str = "rest"
    poses: tuple[str, ...] = ()
    layers: tuple = ()
    images: tuple = ()
    image_keys: tuple = ()
    rank: tuple = ()
    canvas: tuple[int, int] = (0, 0)
    background: Any = (0, 0, 0, 0)
    underlay: dict | None = None
    underlay_image: Any = None
    undo_label: str | None = None
    redo_label: str | None = None
    history: tuple[str, ...] = ()  # the undo stack's labels, oldest first (the History panel)
    future: tuple[str, ...] = ()  # the redo stack's labels, the next redo first
    dirty: bool = False
    preview: bool = False
    done: int = 0  # id of the last job that had run when this was published
    time: float | None = None  # the animation time shown (None: a pose)
    animation: dict | None = None  # the scene's "animation" as in the file (keys, fps)
    ghosts: tuple = ()  # onion skin: (side "before" | "after", weight 0..1, layers)

    @property
    def loaded(self) -> bool:
        return self.data is not None


@dataclass
class Message:
    text: str
    level: str = "info"  # info | error
    time: float = field(default_factory=time.monotonic)


class FrameCache:
    """Solved frames of the animation (scene thread), for one scene state at a time: an
    edit makes a new state and the frames of the old one go."""

    def __init__(self, size: int = FRAME_CACHE):
        self.size = size
        self._data = None
        self._frames: collections.OrderedDict = collections.OrderedDict()

    def clear(self) -> None:
        self._data, self._frames = None, collections.OrderedDict()

    def _for(self, data) -> collections.OrderedDict:
        if self._data is not data:
            self._data, self._frames = data, collections.OrderedDict()
        return self._frames

    def layers_at(self, scene, t: float) -> tuple:
        """The scene's layers at animation time ``t``, solved once per scene state."""
        frames = self._for(scene.data)
        k = round(float(t), 6)
        if k in frames:
            frames.move_to_end(k)
            return frames[k]
        layers = frames[k] = tuple(scene.layers(time=float(t)))
        if len(frames) > self.size:
            frames.popitem(last=False)
        return layers

    def missing(self, data, times) -> list[float]:
        frames = self._frames if self._data is data else {}
        return [t for t in times if t not in frames]

    def count(self, data) -> int:
        """Frames solved for scene state ``data`` (a glance from any thread)."""
        return len(self._frames) if self._data is data else 0


def build_snapshot(session, version: int, layers=None) -> Snapshot:
    """The full snapshot of ``session``'s scene as it is now (scene thread); ``layers``:
    shown instead of the solved pose."""
    s, shown = session.scene, session.shown
    built = s.built
    doc = s.to_dict()
    anim = doc.get("animation")
    t = shown.time if not shown.rest and anim and anim.get("keys") else None
    ghosts = ()
    if t is not None and shown.onion:
        ghosts = tuple((side, weight, session.frames.layers_at(s, gt))
                       for side, weight, gt in onion.ghost_times(anim, t, **dict(shown.onion)))
    if layers is None:
        layers = session.frames.layers_at(s, t) if t is not None else s.layers("rest" if shown.rest else None)
    h = s.history
    underlay = s.underlay
    try:
        under_img = s.underlay_image() if underlay else None
    except SceneError as e:
        session.say(str(e), "error")
        under_img = None
    return Snapshot(
        version=version, file=s.file, data=s.data, active=s.active_pose,
        shown=f"{t:.2f} s" if t is not None else ("rest" if shown.rest else s.active_pose),
        poses=tuple(s.pose_names()), layers=tuple(layers), images=tuple(built.images),
        image_keys=tuple(built.image_keys), rank=tuple(built.rank), canvas=tuple(s.canvas),
        background=s.background(), underlay=underlay, underlay_image=under_img,
        undo_label=h.undo_stack[-1].label if h.can_undo() else None,
        redo_label=h.redo_stack[-1].label if h.can_redo() else None,
        history=tuple(step.label for step in h.undo_stack), future=tuple(step.label for step in reversed(h.redo_stack)),
        dirty=session.saved_doc is None or doc != session.saved_doc, done=session.done,
        time=t, animation=anim, ghosts=ghosts)
