"""Links between two layers, as the meshes see them: segments (shared edges), points
(hinges: one shared vertex the two layers turn about) and polygons (a shared patch: its
outline is shared and its inside stiffened, so it moves as one).

Segments and polygon edges that leave the overlap of the two masks are clipped to the
longest part inside it (``puppet check`` notes it); one with nothing inside is refused.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from puppet.errors import SceneError
from puppet.scene.format.model import SceneData

#: Sampling step along a segment when testing it against the masks, px.
STEP = 0.25


@dataclass
class LinkParts:
    """What every link contributes to the meshes.

    segments : (link index, JSON path, (2, 2) segment) after clipping, polygon edges included.
    points : (link index, JSON path, (2,) hinge point).
    notes : what ``puppet check`` says about clipped segments.
    """

    segments: list[tuple[int, str, np.ndarray]] = field(default_factory=list)
    points: list[tuple[int, str, np.ndarray]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def _grown(im):
    """The mask grown by 1 px (a 3x3 dilation, nothing beyond its border), rows then
    columns: what ``cv2.dilate`` with a 3x3 kernel gives, without loading OpenCV in the
    commands that draw nothing (``mesh``, ``check``)."""
    m = np.asarray(im.mask, bool)
    rows = m.copy()
    rows[1:] |= m[:-1]
    rows[:-1] |= m[1:]
    out = rows.copy()
    out[:, 1:] |= rows[:, :-1]
    out[:, :-1] |= rows[:, 1:]
    return out


def clip_masks(images) -> list:
    """``(mask grown by 1 px, offset, mask)`` of each built image, as :func:`clip_segment`
    and :func:`link_parts` test link segments against them (the app's link pencil too)."""
    return [(_grown(im), im.offset, im.mask) for im in images]


def _inside(grown, offset, P) -> np.ndarray:
    """Which points P (s, 2) lie on a pixel of ``grown`` (the mask grown by 1 px)."""
    Q = np.asarray(P, np.float64) - np.asarray(offset, np.float64)
    j = np.floor(Q[:, 0]).astype(np.int64)
    i = np.floor(Q[:, 1]).astype(np.int64)
    h, w = grown.shape
    ok = (i >= 0) & (i < h) & (j >= 0) & (j < w)
    out = np.zeros(len(Q), bool)
    out[ok] = grown[i[ok], j[ok]]
    return out


def clip_segment(seg: np.ndarray, masks) -> np.ndarray | None:
    """The longest part of ``seg`` (2, 2) whose samples (every :data:`STEP` px) all lie
    inside every ``(grown mask, offset, mask)`` of ``masks`` (the mask grown by 1 px:
    a segment drawn on an edge passes); ``seg`` itself when all of it does. Otherwise the
    longest run inside the masks themselves, its ends pulled in by half a pixel; None when
    less than two samples are inside."""
    seg = np.asarray(seg, np.float64)
    box = _box_part(seg, masks)  # never sample far outside the images
    if box is None:
        return None
    length = float(np.linalg.norm(box[1] - box[0]))
    n = max(2, int(np.ceil(length / STEP)) + 1)
    t = np.linspace(0.0, 1.0, n)
    P = box[0] + t[:, None] * (box[1] - box[0])
    ok = np.ones(n, bool)
    for grown, offset, _ in masks:
        ok &= _inside(grown, offset, P)
    if ok.all():
        return seg if box is seg else np.array([P[0], P[-1]])
    # cut on the masks themselves (not grown), so the ends lie inside the meshes' outlines
    ok = np.ones(n, bool)
    for _, offset, mask in masks:
        ok &= _inside(mask, offset, P)
    # longest run of consecutive inside samples
    d = np.diff(np.concatenate([[0], ok.view(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    if len(starts) == 0:
        return None
    r = int(np.argmax(ends - starts))
    a, z = starts[r], ends[r] - 1
    if z - a < 1:
        return None
    pull = min(2, (z - a) // 4)  # half a pixel in from each end when there is room
    return np.array([P[a + pull], P[z - pull]])


def _box_part(seg, masks):
    """``seg`` itself when it lies in the common box of the masks (grown by 1 px), else
    its part inside that box (Liang-Barsky), or None."""
    lo = np.max([np.asarray(o, np.float64) - 1 for _, o, _ in masks], axis=0)
    hi = np.min([np.asarray(o, np.float64) + g.shape[::-1] + 1 for g, o, _ in masks], axis=0)
    if ((seg >= lo) & (seg <= hi)).all():
        return seg
    d = seg[1] - seg[0]
    t0, t1 = 0.0, 1.0
    for k in range(2):
        for p, q in ((-d[k], seg[0][k] - lo[k]), (d[k], hi[k] - seg[0][k])):
            if p == 0:
                if q < 0:
                    return None
                continue
            r = q / p
            if p < 0:
                t0 = max(t0, r)
            else:
                t1 = min(t1, r)
    if t1 <= t0:
        return None
    return np.array([seg[0] + t0 * d, seg[0] + t1 * d])


def link_parts(data: SceneData, images) -> LinkParts:
    """Clip every link's segments and polygon edges to the overlap of its two layers'
    masks and check its points. Raises SceneError for a part with nothing inside."""
    index = {L.name: L.index for L in data.layers}
    grown = {}
    out = LinkParts()
    for li, link in enumerate(data.links):
        ab = [index[n] for n in link.layers]
        for k in ab:
            if k not in grown:
                grown[k] = (_grown(images[k]), images[k].offset, images[k].mask)
        masks = [grown[k] for k in ab]
        both = f"layers {link.layers[0]!r} and {link.layers[1]!r}"
        edges = [(f"links[{li}].segments[{si}]", s) for si, s in enumerate(link.segments)]
        for pi, P in enumerate(link.polygons):
            edges += [(f"links[{li}].polygons[{pi}]", np.array([P[e], P[(e + 1) % len(P)]])) for e in range(len(P))]
        kept_polygon = set()
        for path, seg in edges:
            c = clip_segment(seg, masks)
            if c is None:
                if ".segments[" in path:
                    raise SceneError(f"no part of the segment lies inside both {both} (a link segment must "
                                     "overlap both layers)", file=data.file, path=path)
                continue  # a polygon edge outside: the rest of its outline still links
            if c is not seg:
                out.notes.append(f"{path}: the part outside {both} was cut off (linked from "
                                 f"({c[0][0]:.1f}, {c[0][1]:.1f}) to ({c[1][0]:.1f}, {c[1][1]:.1f}))")
            kept_polygon.add(path)
            out.segments.append((li, path, c))
        for pi in range(len(link.polygons)):
            path = f"links[{li}].polygons[{pi}]"
            if path not in kept_polygon:
                raise SceneError(f"no part of the polygon's outline lies inside both {both}",
                                 file=data.file, path=path)
        for qi, q in enumerate(link.points):
            if not all(_inside(g, o, q[None])[0] for g, o, _ in masks):
                raise SceneError(f"hinge point ({q[0]:g}, {q[1]:g}) is not inside both {both}",
                                 file=data.file, path=f"links[{li}].points[{qi}]")
            out.points.append((li, f"links[{li}].points[{qi}]", np.asarray(q, np.float64)))
    return out


def coupling(strength: float) -> float:
    """Spring weight ``kappa`` of a link of ``strength`` s < 1: ``s / (1 - s)`` (cotangent
    weights are about 0.3-1, so s = 0.5 couples like one mesh edge, s = 0.99 like 100)."""
    s = float(strength)
    return s / (1.0 - s)
