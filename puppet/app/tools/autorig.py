""""Rig automatically" in the Link and Pins steps: the anatomy rig of the scene's visible
layers (:func:`puppet.scene.make.anatomy.rig_scene`) is proposed first, drawn over the
canvas (pins as dots, hinges as rings, glue segments as lines; :func:`puppet.app.ui.overlay.draw_rig_proposal`),
and becomes part of the scene only when accepted, in one undo step ("rig automatically").
Pins go only to layers with none and links only between layers not linked, so a user's
own rig is kept; the proposal is dropped when the scene changes under it.
"""
from __future__ import annotations

from dataclasses import dataclass

from puppet.scene.make.anatomy import RIG_DEFORMER, rig_scene


@dataclass
class Proposal:
    """What "Rig automatically" found for the scene data ``data`` (pins and links in the
    file's form)."""

    pins: list
    links: list
    data: object


def propose(app) -> None:
    """Find the rig on the scene thread; it is shown (``app.script.rig_proposal``) once found."""
    app.script.rig_proposal = None

    def job(s):
        data = s.data
        rig = rig_scene(s)
        app.script.rig_proposal = Proposal(rig.pins, rig.links, data)
        if not rig.pins and not rig.links:
            return "rig automatically: nothing to add (every part is pinned and linked)"
        hinges = sum(1 for k in rig.links if k.get("points"))
        return (f"proposed: {len(rig.pins)} pins, {hinges} hinges, {len(rig.links) - hinges} glued parts: "
                "Accept adds them (one undo step), Discard drops them")
    app.edit(job)


def current(app) -> Proposal | None:
    """The proposal, while the scene it was made for is the one shown."""
    p = getattr(app.script, "rig_proposal", None)
    if p is not None and app.snap.data is not p.data:
        return None
    return p


def accept(app) -> None:
    p = current(app)
    app.script.rig_proposal = None
    if p is not None:
        app.edit(lambda s: ("rigged automatically: "
                            f"{len(p.pins)} pins, {len(p.links)} links" if s.add_rig(p.pins, p.links, RIG_DEFORMER)
                            else "rig automatically: nothing added"))


def discard(app) -> None:
    app.script.rig_proposal = None
