"""File > Retarget motion (issue 35): a BVH clip read, the pins' map to its joints found
automatically and corrected by the user, then the keys written as one undo step
(:mod:`puppet.motion`, as ``puppet retarget`` does). No GL: the dialog
(:mod:`puppet.app.ui.retarget_dialog`) draws this state."""
from __future__ import annotations

import os
from dataclasses import dataclass, field

from puppet.errors import SceneError
from puppet.motion.bvh import Motion, read_bvh
from puppet.motion.project import PROJECTIONS
from puppet.motion.retarget import SCALES, animation, retarget

#: The dialog's projection choices ("auto": sagittal for a character drawn in profile).
PROJECTION_CHOICES = ("auto",) + tuple(PROJECTIONS)
#: The map's choice for a pin that follows no joint.
NONE = "(none)"


@dataclass
class RetargetForm:
    """The dialog's fields, the clip read and the map shown."""

    path: str = ""
    projection: int = 0  # index into PROJECTION_CHOICES
    scale: int = 0  # index into SCALES
    in_place: bool = False
    motion: Motion | None = None
    read_from: str = ""  # the path the clip was read from
    map: dict[str, str] = field(default_factory=dict)  # pin -> joint (or NONE)
    error: str = ""

    def options(self) -> dict:
        return {"projection": PROJECTION_CHOICES[self.projection], "scale": SCALES[self.scale],
                "in_place": self.in_place}


def form(app) -> RetargetForm:
    f = app.__dict__.get("retarget_form")
    if f is None:
        f = app.__dict__["retarget_form"] = RetargetForm()
    return f


def pins_of(app) -> dict:
    """The pins a motion can move: every pin but starch pins, at rest."""
    return {p.name: p.at for p in app.snap.data.pins if p.kind != "starch"}


def labels_of(app) -> dict:
    """Each pin's layer name (the automatic map reads a side from it: ``p7`` on ``leftleg``)."""
    return {p.name: p.layer for p in app.snap.data.pins if p.kind != "starch"}


def read(app, f: RetargetForm) -> bool:
    """Read the clip at ``f.path`` and find the map automatically; False (and
    ``f.error``) where the clip or the scene cannot be used."""
    f.error = ""
    try:
        pins = pins_of(app)
        if not pins:
            raise SceneError("the scene has no pins to move: add pins first (Pins step)")
        f.motion = read_bvh(os.path.expanduser(f.path.strip()))
        f.read_from = f.path.strip()
        r = retarget(f.motion, pins, labels=labels_of(app), **f.options())
    except (SceneError, OSError, ValueError) as e:
        f.motion, f.map, f.error = None, {}, str(e)
        return False
    f.map = {p: r.map.get(p, NONE) for p in pins}
    return True


def write(app, f: RetargetForm) -> int | None:
    """Write the keys of the clip with the map shown (one undo step: the scene's animation
    replaced); the status line says how many."""
    if f.motion is None:
        return None
    motion, mapping, options = f.motion, {p: j for p, j in f.map.items() if j != NONE}, f.options()
    name = os.path.basename(f.read_from)
    if not mapping:
        f.error = "the map moves no pin: choose a joint for at least one pin"
        return None

    def fn(s):
        pins = {p.name: p.at for p in s.data.pins if p.kind != "starch"}
        r = retarget(motion, pins, mapping={p: j for p, j in mapping.items() if p in pins}, **options)
        anim = animation(r)
        s.set_animation(anim, f"retarget {name}")
        return f"{name}: {len(r.times)} frames ({r.times[-1]:.2f} s, {r.projection}) onto {len(r.map)} pins, " \
               f"{len(anim['keys'])} keys (one undo step)"
    return app.edit(fn)
