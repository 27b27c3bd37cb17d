"""What is left of a layer when a part is cut out of it: the layer's outline completed
smoothly across the part (Photoshop's Layer via Cut, with the body refilled behind).

The outline a layer "would have without the part" is found on the layer's own outline:
each run of outline pixels that lies inside the part (where the part stuck out of the
body, or covered its edge) is replaced by a cubic Bezier from the last outline pixel
before the run to the first one after it, leaving and arriving along the outline's own
tangents there, with the handle length that makes a cubic reproduce a circular arc
(``4/3 tan(theta/4) R`` for an arc turning by ``theta`` over radius ``R``). So a disc with
a bar stuck on it gets its round edge back, a straight edge stays straight, and a band
cut right through a body is bridged from one side to the other (both edges of the band
are runs). Outline pieces wholly inside the part go (an enclosed hole of the layer that
lies inside the part is filled: the body is refilled under it).

The tangent at a run's end is that of the least-squares circle through the last
16 outline pixels before it, smoothed along the outline first (a Gaussian of 2 points,
which takes out the pixel staircase), or of their line when they are straight or the
line fits them much better: exact on a circle and on a straight line. Fitted to the raw
pixels, the tangent beside the gopher's cut arm was tilted by 12-24 degrees and the
completed edge bit 3 px into the body; smoothed, it stays within about a pixel.
"""
from __future__ import annotations

import numpy as np

from puppet.imaging.inpaint import INK, outline_ink

#: a run's end tangent is fitted to at most this many outline points before it
FIT = 16
#: the outline points a tangent is fitted to are first smoothed along the outline by a
#: Gaussian of this many points (the pixel staircase otherwise tilts a 16-point circle fit)
SMOOTH = 2.0
#: slivers of the layer at most this wide (px) left between a cut region and the layer's
#: outside go with the part (:func:`cut_apart`): a lasso that crossed a thick outline ...
EDGE = 12.0
#: ... or this fraction of the diagonal of the part's box, when that is wider (outlines
#: and a hand's slips grow with the picture)
REACH = 0.1
#: ... where the part and the outside lie on opposite sides of the sliver, within this angle
#: (radians); a narrower wedge between a lasso and the layer's edge counts as a sliver too
ACROSS = np.pi / 4
#: ... in pieces of at least this many pixels (a pixel or two of the body's edge beside
#: where a lasso crossed it is no sliver)
MIN_PIECE = 4
#: the distances' gradients that give those directions are taken after a Gaussian of this
#: many pixels (the nearest pixels themselves turn by 45 degrees from a pixel to the next)
GRADIENT = 2.0
#: a run of fewer outline points than this left between two cut runs is bridged with them
MIN_KEPT = 3


def fit_tangent(Q: np.ndarray) -> np.ndarray | None:
    """Unit tangent at the last of the points ``Q`` (k, 2), travelling along them: of the
    least-squares circle through them (an algebraic fit), or of their principal line when
    they are (nearly) straight. None for fewer than two distinct points."""
    Q = np.asarray(Q, float)
    travel = Q[-1] - Q[0]
    if len(Q) < 2 or not travel.any():
        return None
    m = Q.mean(axis=0)
    X = Q - m
    _, sv, vt = np.linalg.svd(X, full_matrices=False)
    t, scale = vt[0], np.abs(X).max()
    if len(Q) >= 3 and sv[-1] > 1e-9 * sv[0]:  # not collinear: the algebraic circle fit
        A = np.column_stack([X, np.ones(len(X))])
        sol, *_ = np.linalg.lstsq(A, (X ** 2).sum(axis=1), rcond=None)
        centre = sol[:2] / 2.0
        r2 = sol[2] + centre @ centre
        if 0 < r2 < (1e3 * max(scale, 1.0)) ** 2 and _fits_better(X, centre, np.sqrt(r2), sv[-1]):
            rad = Q[-1] - (centre + m)
            t = np.array([-rad[1], rad[0]])
    t = t / np.linalg.norm(t)
    return t if t @ travel >= 0 else -t


def _fits_better(X: np.ndarray, centre: np.ndarray, radius: float, line_sv: float) -> bool:
    """Does the circle (``centre``, ``radius``) fit the centred points ``X`` (k, 2) about as
    well as their principal line (smallest singular value ``line_sv``) or better (RMS
    distance within half a pixel of the line's, and at most twice it)? The algebraic fit
    of a pixel staircase on a nearly straight edge can give a tiny circle centred among
    the points, whose tangent points across the edge: seen on the gopher's body, 2.3 px
    off against 0.25 px for the line."""
    circle = np.sqrt(np.mean((np.hypot(*(X - centre).T) - radius) ** 2))
    line = line_sv / np.sqrt(len(X))
    return bool(circle <= max(2.0 * line, line + 0.5))


def arc_bezier(a, ta, b, tb, samples: int | None = None) -> np.ndarray:
    """A cubic Bezier from ``a`` (leaving along unit ``ta``) to ``b`` (arriving along unit
    ``tb``), with handles of the length that fits a circular arc turning by the angle
    between the tangents: (samples, 2) points, both ends included.

    Hand-checked: a = (1, 0), ta = (0, 1), b = (0, 1), tb = (-1, 0) (a quarter of the unit
    circle) keeps the curve within 3e-4 of radius 1.
    """
    a, b, ta, tb = (np.asarray(v, float) for v in (a, b, ta, tb))
    c = float(np.linalg.norm(b - a))
    theta = abs(float(np.arctan2(ta[0] * tb[1] - ta[1] * tb[0], ta @ tb)))
    theta = min(theta, np.pi * 0.999)
    if theta < 1e-6:
        h = c / 3.0
    else:
        h = 4.0 / 3.0 * np.tan(theta / 4.0) * c / (2.0 * np.sin(theta / 2.0))
    n = samples or max(int(np.ceil(c)) + 2, 4)
    s = np.linspace(0.0, 1.0, n)[:, None]
    p1, p2 = a + h * ta, b - h * tb
    return (1 - s) ** 3 * a + 3 * (1 - s) ** 2 * s * p1 + 3 * (1 - s) * s ** 2 * p2 + s ** 3 * b


def _kept_run(cut: np.ndarray, i: int, step: int) -> np.ndarray:
    """Indices of the uncut points from ``i`` going ``step`` (+1 / -1) round the contour,
    at most FIT of them, ``i`` first."""
    n = len(cut)
    idx = (i + step * np.arange(min(FIT, n))) % n
    stop = np.flatnonzero(cut[idx])
    return idx[:stop[0]] if stop.size else idx


def _smooth(Q: np.ndarray) -> np.ndarray:
    """Outline points (k, 2) smoothed along the outline (Gaussian of :data:`SMOOTH` points,
    ends held): the staircase of a pixel outline taken out before a tangent is fitted."""
    if SMOOTH <= 0 or len(Q) < 3:
        return Q
    from scipy.ndimage import gaussian_filter1d  # lazy: cuts only (see the module's startup-import test)

    return gaussian_filter1d(np.asarray(Q, float), SMOOTH, axis=0, mode="nearest")


def _bridge_gaps(cut: np.ndarray, least: int) -> np.ndarray:
    """``cut`` (n,) bool round a closed contour with its runs of uncut points shorter than
    ``least`` between two cut runs counted as cut (a lone outline pixel a lasso left would
    otherwise be an end of two arcs), unless no longer uncut run would be left."""
    start = int(np.flatnonzero(cut)[0])
    c = np.roll(cut, -start)  # begins with a cut point: no uncut run wraps
    edges = np.diff(np.r_[c.astype(np.int8), 1])
    runs = list(zip(np.flatnonzero(edges == -1) + 1, np.flatnonzero(edges == 1) + 1))  # [i, j) uncut
    if all(j - i < least for i, j in runs):
        return cut
    c = c.copy()
    for i, j in runs:
        if j - i < least:
            c[i:j] = True
    return np.roll(c, start)


def complete_ring(P: np.ndarray, cut: np.ndarray) -> np.ndarray | None:
    """One closed pixel outline with its runs of ``cut`` points bridged by arcs.

    Parameters
    ----------
    P : (n, 2) float
        Outline points (x, y) in order (a closed contour).
    cut : (n,) bool
        Points that lie inside the part being cut out.

    Returns
    -------
    (m, 2) float, the completed closed outline, or None when every point is cut.
    """
    n = len(P)
    if cut.all():
        return None
    P = np.asarray(P, float)
    if not cut.any():
        return P
    cut = _bridge_gaps(cut, MIN_KEPT)
    start = int(np.flatnonzero(~cut)[0])  # begin on an outline point, so no run wraps
    P, cut = np.roll(P, -start, axis=0), np.roll(cut, -start)
    edges = np.diff(np.r_[0, cut.astype(np.int8), 0])
    runs = zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))  # [i, j) of cut points
    out: list[np.ndarray] = []
    kept_from = 0
    for i, j in runs:
        out.append(P[kept_from:i])
        a, b = i - 1, j % n  # the outline points either side of the run
        chord = P[b] - P[a]
        dflt = chord / (np.linalg.norm(chord) or 1.0)
        ta = fit_tangent(_smooth(P[_kept_run(cut, a, -1)[::-1]]))
        tb = fit_tangent(_smooth(P[_kept_run(cut, b, +1)[::-1]]))  # travelling backwards from b
        out.append(arc_bezier(P[a], dflt if ta is None else ta, P[b], dflt if tb is None else -tb)[1:-1])
        kept_from = j
    out.append(P[kept_from:])
    return np.concatenate(out)


def completed_body(mask: np.ndarray, part: np.ndarray) -> np.ndarray:
    """The region a layer's outline encloses once completed across ``part``: (h, w) bool.

    Parameters
    ----------
    mask : (h, w) bool
        The layer's pixels.
    part : (h, w) bool
        The pixels being cut out (inside ``mask``).

    Returns
    -------
    (h, w) bool: inside the completed outer outlines and outside the completed holes
    (even-odd over all of them). Only its pixels inside ``part`` matter to a cut.
    """
    import cv2  # lazy: cuts only (OpenCV is not loaded outside drawing)

    m8 = np.ascontiguousarray(mask, np.uint8)
    contours, _ = cv2.findContours(m8, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    rings = []
    for c in contours:
        P = c.reshape(-1, 2)
        R = complete_ring(P, part[P[:, 1], P[:, 0]])
        if R is not None and len(R) >= 3:
            rings.append(np.round(R * 16).astype(np.int32))
    out = np.zeros(mask.shape, np.uint8)
    if rings:
        cv2.fillPoly(out, rings, 1, lineType=cv2.LINE_8, shift=4)
    return out.astype(bool)


def sliver_width(part: np.ndarray) -> float:
    """The widest sliver a cut of ``part`` leaves that goes with it (px): :data:`EDGE`, or
    :data:`REACH` of the diagonal of the part's box when that is more."""
    rows, cols = np.flatnonzero(part.any(axis=1)), np.flatnonzero(part.any(axis=0))
    if not rows.size:
        return EDGE
    return max(EDGE, REACH * float(np.hypot(rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1)))


def edge_strip(mask: np.ndarray, part: np.ndarray, width: float) -> np.ndarray:
    """The layer's pixels outside ``part`` that a cut leaves hanging off the part: slivers
    at most ``width`` px wide between ``part`` and the layer's outside, and thin pieces cut
    off by it. (h, w) bool.

    A sliver pixel's distance to ``part`` plus its distance to the outside (pixel centres,
    the image's border counted as outside) is at most ``width + 1``, and the two lie on
    opposite sides of it: the distances' gradients point the same way within
    :data:`ACROSS`. A sliver ``t`` px thick left between a lasso and the layer's edge has
    ``t + 1`` everywhere and its directions agree; beside a cut straight across a limb
    thinner than ``width`` they are square, so the limb keeps its end. Slivers come in
    pieces of :data:`MIN_PIECE` pixels or more (the pixel at the corner where a lasso
    crossed the layer's edge is no sliver). The thin pieces are :func:`_debris`.

    Computed on the part's box grown by ``width + 2``, which holds every such pixel and
    its nearest outside pixel.
    """
    out = np.zeros(mask.shape, bool)
    box = _box(part, width)
    if box is None:
        return out
    d_out = _distance_out(mask, box)
    d_part = _distance(~part[box])
    strip = _pieces(mask[box] & ~part[box] & (d_out + d_part <= width + 1) & _across(d_part, d_out), MIN_PIECE)
    edge = [box[0].start > 0, box[0].stop < mask.shape[0], box[1].start > 0, box[1].stop < mask.shape[1]]
    out[box] = strip | _debris(mask[box] & ~part[box] & ~strip, part[box] | strip, width, edge)
    return out


def _box(part: np.ndarray, width: float) -> tuple[slice, slice] | None:
    """The part's box grown by ``width + 2`` (clipped by the image: slicing clips), or None
    for no part or no width."""
    rows, cols = np.flatnonzero(part.any(axis=1)), np.flatnonzero(part.any(axis=0))
    if not rows.size or width <= 0:
        return None
    m = int(np.ceil(width)) + 2
    return slice(max(rows[0] - m, 0), rows[-1] + m + 1), slice(max(cols[0] - m, 0), cols[-1] + m + 1)


def _distance_out(mask: np.ndarray, box) -> np.ndarray:
    """Each pixel's distance to the layer's outside in ``box``, the image's border counted as outside."""
    inside = np.pad(mask, 1)[box[0].start:box[0].stop + 2, box[1].start:box[1].stop + 2]
    return _distance(inside)[1:-1, 1:-1]


def _across(d_from: np.ndarray, d_to: np.ndarray) -> np.ndarray:
    """Where the direction away from what ``d_from`` measures the distance to and the
    direction towards what ``d_to`` measures it to agree within :data:`ACROSS` (the
    distances' gradients, smoothed): a pixel between the two, on a line across."""
    import cv2  # lazy: cuts only

    g_from = np.gradient(cv2.GaussianBlur(d_from, (0, 0), GRADIENT))
    g_to = np.gradient(cv2.GaussianBlur(d_to, (0, 0), GRADIENT))
    dot = -(g_from[0] * g_to[0] + g_from[1] * g_to[1])
    return dot >= np.cos(ACROSS) * np.hypot(*g_from) * np.hypot(*g_to)


def _distance(a: np.ndarray) -> np.ndarray:
    """Each pixel's Euclidean distance to the nearest pixel of ``a`` that is False: (h, w) float32."""
    import cv2  # lazy: cuts only

    return cv2.distanceTransform(a.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def _label(a: np.ndarray) -> tuple[np.ndarray, int]:
    """The 8-connected pieces of ``a``: labels (0 off ``a``, 1..n) and n."""
    import cv2  # lazy: cuts only

    n, lab = cv2.connectedComponents(a.astype(np.uint8), connectivity=8)
    return lab, n - 1


def _pieces(a: np.ndarray, least: int) -> np.ndarray:
    """The 8-connected pieces of ``a`` of at least ``least`` pixels."""
    lab, n = _label(a)
    big = np.bincount(lab.ravel(), minlength=n + 1) >= least
    big[0] = False
    return big[lab]


def _debris(rest: np.ndarray, cut: np.ndarray, width: float, open_sides) -> np.ndarray:
    """The pieces of ``rest`` (the layer's pixels left, in the part's box) that touch
    ``cut``, are nowhere wider than ``width`` and lie wholly in the box (not touching its
    sides where ``open_sides`` (top, bottom, left, right) is true, where the layer goes on),
    all but the largest piece: (h, w) bool. What a lasso leaves of a thin stroke it
    crossed: a lone outline pixel, a few pixels of a stick."""
    lab, n = _label(rest)
    if n < 2:
        return np.zeros_like(rest)
    bad = np.zeros(n + 1, bool)
    bad[np.unique(lab[_grow(cut) & rest])] = True
    for side, going_on in zip((lab[0], lab[-1], lab[:, 0], lab[:, -1]), open_sides):
        if going_on:
            bad[side] = False
    thick = np.zeros(n + 1, np.float32)
    np.maximum.at(thick, lab.ravel(), _distance(np.pad(rest, 1))[1:-1, 1:-1].ravel())
    bad &= thick <= width / 2.0
    bad[0] = False
    bad[1 + np.argmax(np.bincount(lab.ravel(), minlength=n + 1)[1:])] = False
    return bad[lab]


def _outside_pieces(strip: np.ndarray, body: np.ndarray) -> np.ndarray:
    """The 8-connected pieces of ``strip`` with at most half their pixels in ``body``."""
    lab, n = _label(strip)
    count = np.bincount(lab.ravel(), minlength=n + 1)
    inside = np.bincount(lab[body], minlength=n + 1)
    keep = 2 * inside <= count
    keep[0] = False
    return keep[lab]


def ink_slivers(rgb: np.ndarray, mask: np.ndarray, part: np.ndarray, body: np.ndarray,
                width: float) -> np.ndarray:
    """What a region left of the drawing's lines over the body: (h, w) bool.

    On a drawing with an outline (:func:`~puppet.imaging.inpaint.outline_ink`, looked for
    in the layer's pixels near the part), a hand drawn over the body has its outline in
    that ink too. A lasso drawn inside that outline leaves a band of it on the body, which
    shows as a dark crescent once the hand moves. Those are
    the pixels of ``body`` (the completed outline) outside ``part`` that have the ink's
    colour (within :data:`INK`), lie between ``part`` and pixels of another colour on a
    line across (as :func:`edge_strip`'s slivers lie between the part and the outside),
    at most ``width + 1`` from the two together, in pieces that touch the part's own
    ink-coloured pixels, with the anti-aliased pixels round them. The body's own outline
    where a lasso crossed it runs along the cut, not across it, and stays.
    """
    out = np.zeros(mask.shape, bool)
    box = _box(part, width)
    if box is None:
        return out
    m, p, c = mask[box], part[box], rgb[box][..., :3].astype(np.float32)
    found = outline_ink(c, m & ~p, _distance_out(mask, box))
    if found is None:
        return out
    inky = np.linalg.norm(c - found[0], axis=-1) <= INK
    rest = m & ~p
    d_part, d_other = _distance(~p), _distance(~(rest & ~inky))
    band = rest & inky & body[box] & (d_part + d_other <= width + 1) & _across(d_part, d_other)
    lab, n = _label(band)
    touching = np.zeros(n + 1, bool)
    touching[np.unique(lab[_grow(p & inky)])] = True
    touching[0] = False
    slivers = touching[lab] & (np.bincount(lab.ravel(), minlength=n + 1) >= MIN_PIECE)[lab]
    # with the anti-aliased pixels round them: nearer the ink than the body's own colour is
    other = rest & ~inky
    if other.any():
        to_ink = np.linalg.norm(c - found[0], axis=-1)
        fill = np.linalg.norm(np.median(c[other], axis=0) - found[0])
        slivers |= _grow(slivers) & rest & body[box] & (to_ink < fill - INK / 2)
    out[box] = slivers
    return out


def _grow(a: np.ndarray) -> np.ndarray:
    """``a`` grown by one pixel (8-connected)."""
    import cv2  # lazy: cuts only

    return cv2.dilate(a.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def cut_apart(mask: np.ndarray, part: np.ndarray, width: float | None = None, rgb: np.ndarray | None = None) \
        -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A layer cut apart by a region: what the part takes, what the layer keeps, and what
    it refills.

    The region rarely follows the layer's edge: a lasso drawn round a cup on a drawing
    with a thick outline crosses the outline back and forth, and leaves slivers of it (or
    a lone edge pixel) outside the region. The completion would take those for the
    layer's own edge and close the outline round the whole cup. So the pixels of
    :func:`edge_strip` count as cut when the outline is completed, and those of them left
    outside the completed outline go with the part; the others (beside where the region
    crossed the body's edge) stay in the layer as they are.

    Parameters
    ----------
    mask : (h, w) bool
        The layer's pixels.
    part : (h, w) bool
        The pixels the region selects (only those inside ``mask`` count).
    width : float, optional
        The widest sliver taken with the part (px): by default :func:`sliver_width`; 0
        takes the region's pixels only.
    rgb : (h, w, 3 or 4) array, optional
        The layer's colours: with them, :func:`ink_slivers` go with the part too (the
        layer keeps them, refilled).

    Returns
    -------
    taken : (h, w) bool
        The new layer's pixels: ``part`` and the slivers.
    keep : (h, w) bool
        The layer's mask after the cut: ``mask`` without ``taken``, plus the part's pixels
        inside the completed outline.
    refill : (h, w) bool
        The part's pixels the layer keeps (they need new colours: the part took its own).
    """
    part = part & mask
    width = sliver_width(part) if width is None else width
    strip = edge_strip(mask, part, width)
    if strip.any():  # the pieces the completion finds mostly inside are the body's own edge
        strip = _outside_pieces(strip, completed_body(mask, part | strip))
    body = completed_body(mask, part | strip)
    if rgb is not None:
        part = part | ink_slivers(rgb, mask, part, body, width)
    taken = part | (strip & ~body)
    refill = body & part
    return taken, (mask & ~taken) | refill, refill


def body_after_cut(mask: np.ndarray, part: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A layer's mask after cutting ``part`` out, and the pixels to refill
    (:func:`cut_apart` without what the part takes)."""
    _, keep, refill = cut_apart(mask, part)
    return keep, refill
