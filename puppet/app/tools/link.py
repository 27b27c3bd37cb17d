"""The Link step's pencil: a straight segment from the press to the release between the
two link layers. While it drags, the canvas shows the part the build will keep (the
segment clipped to the overlap of the two masks by :func:`puppet.scene.rig.links.clip_segment`,
the very rule the meshes use) solid, as a stored link is drawn, and the parts it drops
dashed (:func:`puppet.app.ui.overlay.draw_link_preview`). The release adds the kept part as the link segment (one undo step), so the file
holds what is used; only a segment with nothing inside the overlap is refused.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.scene.rig.links import clip_masks, clip_segment

#: dashes of the dropped parts, window px (on, off)
DASH = (6.0, 5.0)
#: a dropped part shorter than this (canvas px) is not shown nor reported: the build pulls
#: the ends of a clipped segment half a pixel into the masks, also at an end drawn inside
MIN_DROP = 1.0


@dataclass
class Preview:
    """The segment being drawn (or just drawn) and what of it is kept.

    p0, p1 : (2,) canvas xy of the press and the pointer (the release once done).
    kept : (2, 2) canvas xy of the kept part, or None (nothing inside the overlap).
    pair : the two layers.
    done : the release happened (the kept part was sent to the scene, or refused).
    job : the scene-thread job that adds the kept part (snapshots with ``done >= job``
        show its result), 0 before the release.
    data : the scene data shown at the release (a refused segment is shown until it changes).
    """

    p0: np.ndarray
    p1: np.ndarray
    kept: np.ndarray | None
    pair: tuple[str, str]
    done: bool = False
    job: int = 0
    data: object = None

    @property
    def length(self) -> float:
        return float(np.hypot(*(self.p1 - self.p0)))

    @property
    def kept_length(self) -> float:
        return 0.0 if self.kept is None else float(np.hypot(*(self.kept[1] - self.kept[0])))

    def dropped(self) -> list[np.ndarray]:
        """The parts of the drawn segment the build drops: (2, 2) canvas segments (those
        longer than :data:`MIN_DROP`)."""
        if self.kept is None:
            return [np.array([self.p0, self.p1])]
        d = self.p1 - self.p0
        n2 = float(d @ d)
        if n2 == 0.0:
            return []
        t = sorted(float((q - self.p0) @ d) / n2 for q in self.kept)
        out = []
        n = np.sqrt(n2)
        if t[0] * n >= MIN_DROP:
            out.append(np.array([self.p0, self.p0 + t[0] * d]))
        if (1 - t[1]) * n >= MIN_DROP:
            out.append(np.array([self.p0 + t[1] * d, self.p1]))
        return out


def link_masks(app, a: str, b: str) -> list | None:
    """``(grown mask, offset, mask)`` of layers ``a`` and ``b`` as the build clips link
    segments with them (:func:`puppet.scene.rig.links.link_parts`), from the shown snapshot;
    cached while the snapshot's version and the pair stay the same."""
    sc = app.script
    key = (app.snap.version, a, b)
    hit = sc.link_masks
    if hit is not None and hit[0] == key:
        return hit[1]
    ka, kb = app.layer_index(a), app.layer_index(b)
    if ka is None or kb is None:
        return None
    masks = clip_masks([app.snap.images[ka], app.snap.images[kb]])
    sc.link_masks = (key, masks)
    return masks


def preview(app, a: str, b: str, p0, p1) -> Preview:
    """What the segment ``p0``-``p1`` (canvas xy) between ``a`` and ``b`` keeps."""
    p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
    masks = link_masks(app, a, b)
    kept = None if masks is None or np.array_equal(p0, p1) else clip_segment(np.array([p0, p1]), masks)
    if kept is not None:
        kept = np.array(kept, np.float64)  # clip_segment may return the drawn array itself
    return Preview(p0, p1, kept, (a, b))


def message(p: Preview) -> str:
    """The status line for ``p``: while it drags, what the release would do; after the
    release, what was kept (info) or why nothing was (an error)."""
    a, b = p.pair
    where = f"where {a} and {b} overlap"
    if p.kept is None:
        if not p.done:
            return f"no part of the segment lies {where} (the tinted area): it would not be added"
        return f"no part of the segment lies {where} (the tinted area): not added; draw it across the tint"
    if p.dropped():
        if not p.done:
            return f"link keeps {p.kept_length:.0f} of {p.length:.0f} px: the dashed part lies outside {where}"
        return f"link kept {p.kept_length:.0f} of {p.length:.0f} px: the rest lies outside {where}"
    return f"link {a} and {b}: {p.kept_length:.0f} px" + ("" if p.done else f", all {where}")


def link_tool(app, press):
    """Link pencil: the segment from the press to the pointer, previewed clipped to the
    overlap of the two link layers; the release adds its kept part (one undo step)."""
    sc = app.script
    sc.link_preview = None
    a, b = sc.link_pair(app)
    if a is None:
        app.say("choose two layers to link (Link panel)", "error")
        return
    ev = press
    try:
        while True:
            sc.link_preview = p = preview(app, a, b, press.xy, ev.xy)
            if ev.type == "release":
                break
            if p.length * app.view.scale >= 2.0:
                app.say(message(p))
            ev = yield
    except GeneratorExit:  # Esc / Ctrl+Z during the drag: nothing drawn stays
        sc.link_preview = None
        raise
    p.done, p.data = True, app.snap.data
    if p.length * app.view.scale < 2.0:
        sc.link_preview = None
        app.say("drag to draw a link segment", "error")
        return
    if p.kept is None:
        app.say(message(p), "error")
        return
    seg = [[float(q[0]), float(q[1])] for q in p.kept]
    text = message(p)

    def job(s):
        s.add_link(a, b, seg)
        return text
    p.job = app.edit(job)


def stored(app, p: Preview) -> bool:
    """The kept part of ``p`` is a segment of the shown scene's link between its layers
    (an undo takes it away, and the dropped parts are then no longer shown)."""
    for link in app.snap.data.links:
        if set(link.layers) == set(p.pair):
            if any(np.allclose(np.asarray(s, float), p.kept) for s in link.segments):
                return True
    return False
