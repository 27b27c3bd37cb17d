"""Canvas tools of the deformation that fits real art (issue 22): the stiffness brush
(paints grey 0..255 into a layer's stiffness image, Alt erases), the hinge tool (a click
in the overlap of two layers adds a link point), the patch tool (clicks make a polygon,
a click on its first point closes it into a link polygon), and the grey levels of the
stiffness heat map (drawn by :mod:`puppet.app.ui.deform_overlay`). The Deform panel (:mod:`puppet.app.ui.deform_panel`) chooses the tool.

Each stroke, hinge or patch is one edit on the scene thread, so one undo step. Points
are taken back to the rest pose through the shown mesh, so the tools work in a pose too.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from puppet.app.model import pick
from puppet.app.tools import mask as masktools
from puppet.app.tools.gestures import click_or_drag
from puppet.errors import SceneError
from puppet.imaging.masks import canvas_to_image
from puppet.scene.rig.stiffness import layer_grey, stiffness_image

#: a click this close to a patch's first point (window pixels) closes the patch
CLOSE_RADIUS = 9.0
TOOLS = ("stiffness", "hinge", "patch")
#: The stiffness brush's grey at first (25 %: a cell weighs 100^0.25 = 3.2 times more, a
#: quarter of it rigid). At 255 one stroke across a garment fitted in `similar` mode kept
#: the band at its size while the rest shrank round it (issue 32).
VALUE = 64


@dataclass
class DeformState:
    """The Deform panel's choices and drafts."""

    tool: str | None = None  # None (the mode's tool) or one of TOOLS
    step: str | None = None  # the task-script step it was chosen in
    mode: str | None = None  # the mode (pin / pose) it was chosen in
    brush: float = 30.0  # stiffness brush diameter, canvas px
    value: int = VALUE  # grey the brush paints (0 normal .. 255 stiffest)
    draft: list = field(default_factory=list)  # patch points so far (rest canvas xy)
    draft_screen: list = field(default_factory=list)  # the same as clicked (shown canvas xy)
    draft_pair: tuple | None = None  # the patch's two layers
    stroke: list | None = None  # the brush stroke in progress (canvas xy)
    link: tuple | None = None  # the selected link's layers (strength slider)
    heat: dict = field(default_factory=dict)  # heat-map cache: layer index -> (scene data, vertex count, grey)


def state(app) -> DeformState:
    """The app's :class:`DeformState` (made on first use)."""
    st = app.__dict__.get("deform")
    if st is None:
        st = app.__dict__["deform"] = DeformState()
    return st


def choose(app, tool: str | None) -> None:
    """The Deform panel's ``tool`` (None: the mode's own) is chosen: it replaces the task
    script step's tool (the Link step's pencil, the Layers step's lasso) until a step or
    a step's tool is chosen again (:func:`sync`)."""
    st = state(app)
    st.tool, st.step, st.mode = tool, app.script.step, app.mode
    cancel_patch(app)
    if tool is not None:
        app.script.tool = None


def sync(app) -> str | None:
    """The Deform panel's tool, given back (None) once a task-script step or a step's tool
    was chosen after it, or the mode was switched (Pin / Pose: a click then does what the
    mode does): the last tool chosen is the canvas's."""
    st = state(app)
    if st.tool is not None and (app.script.tool is not None or (st.step is not None and app.script.step != st.step)
                                or (st.mode is not None and st.mode != app.mode)):
        st.tool = None
        cancel_patch(app)
    return st.tool


def canvas_tool(app):
    """The tool generator function for a left press (None: the mode's own tool)."""
    t = sync(app)
    return {"stiffness": stiffness_tool, "hinge": hinge_tool, "patch": patch_tool}.get(t)


# -- picking (GL thread, from the snapshot) ------------------------------------------
def layers_at(app, xy) -> list[tuple[int, tuple[float, float]]]:
    """The visible layers whose mask covers canvas point ``xy`` in the shown pose, front
    first, each with its rest point there."""
    snap, hidden = app.snap, app.hidden_indices()
    out = []
    for k, r in enumerate(snap.layers):
        if k in hidden:
            continue
        rest = pick.rest_point(r, xy)
        if rest is not None and snap.images[k].contains(rest):
            out.append((k, rest))
    return sorted(out, key=lambda c: -snap.rank[c[0]])


def pair_at(app, xy):
    """(layer a, layer b, rest point) for a link at canvas point ``xy``: in the Link step
    its layer A and B boxes' layers where both cover the point; elsewhere the selected
    layer and the front-most other layer there, or the two front-most; None when fewer
    than two (or not those two) layers cover the point."""
    found = layers_at(app, xy)
    names = [app.snap.data.layers[k].name for k, _ in found]
    if app.script.step == "link":
        a, b = app.script.link_pair(app)
        return (a, b, found[names.index(a)][1]) if a in names and b in names else None
    if len(found) < 2:
        return None
    if app.selected_layer in names:
        i = names.index(app.selected_layer)
        j = 0 if i != 0 else 1
    else:
        i, j = 0, 1
    return names[i], names[j], found[i][1]


def overlap_hint(app) -> str:
    """Which layers a hinge or patch links here, for messages."""
    a, b = app.script.link_pair(app) if app.script.step == "link" else (None, None)
    return f"{a} and {b} (the Link step's layers A and B)" if a is not None else "two layers"


# -- scene-thread job ------------------------------------------------------------------
def paint_stiffness(s, layer: str, shape_fn, value: int) -> str | None:
    """Set ``layer``'s stiffness to ``value`` (0..255) under the canvas-grid mask
    ``shape_fn((H, W))`` (rest canvas), inside the layer's mask: one edit."""
    k = masktools._index(s, layer)
    if k is None:
        raise SceneError(f"no layer named {layer!r}")
    L, im = s.data.layers[k], s.built.images[k]
    W, H = s.canvas
    cut = canvas_to_image(shape_fn((H, W)), im.offset, im.mask.shape) & im.mask
    if not cut.any():
        raise SceneError(f"the stroke does not touch layer {layer!r}")
    old = stiffness_image(s.data, L, im)
    grey = np.zeros(im.mask.shape) if old is None else np.rint(old)
    new = grey.copy()
    new[cut] = value
    if np.array_equal(new, grey):
        return "stiffness: no change"
    s.set_stiffness_pixels(layer, new)
    return None


# -- canvas tools ----------------------------------------------------------------------
def stiffness_tool(app, press):
    """Paint stiffness along the drag (Alt: erase to 0) into the selected layer, or the
    layer under the press."""
    st = state(app)
    found = layers_at(app, press.xy)
    names = [app.snap.data.layers[k].name for k, _ in found]
    layer = app.selected_layer if app.selected_layer in names else (names[0] if names else app.selected_layer)
    k = app.layer_index(layer)
    if k is None:
        app.say("paint on a layer (or select one in the Layers panel)", "error")
        return
    app.selected_layer = layer
    st.stroke = [tuple(press.xy)]
    ev = press
    while ev.type != "release":
        ev = yield
        st.stroke.append(tuple(ev.xy))
    r = app.snap.layers[k]
    rest = [p for p in (pick.rest_point(r, q) for q in st.stroke) if p is not None]
    st.stroke = None
    if not rest:
        app.say(f"the stroke does not touch layer {layer}", "error")
        return
    value, radius = (0 if press.alt else int(st.value)), st.brush / 2.0
    app.edit(lambda s: paint_stiffness(s, layer, lambda sh: masktools.stroke_mask(sh, rest, radius), value))


def hinge_tool(app, press):
    """A click in the overlap of two layers: a hinge (link point) between them."""
    _, went = yield from click_or_drag(press)
    if went:
        return
    pair = pair_at(app, press.xy)
    if pair is None:
        app.say(f"click where {overlap_hint(app)} overlap to hinge them", "error")
        return
    a, b, at = pair
    state(app).link = (a, b)
    for link in app.snap.data.links:
        if set(link.layers) == {a, b} and any(np.hypot(*(q - at)) < 2.0 for q in link.points):
            app.say(f"{a} and {b} are hinged there already", "error")
            return
    app.edit(lambda s: s.add_link_point(a, b, at))
    app.say(f"hinge {a} and {b} at ({at[0]:.0f}, {at[1]:.0f})")


def patch_tool(app, press):
    """Clicks add the patch's corners; a click on its first point closes it into a link
    polygon between the two layers under that point."""
    _, went = yield from click_or_drag(press)
    if went:
        return
    st = state(app)
    if st.draft and len(st.draft) >= 3:
        first = app.view.to_screen(st.draft_screen[0])
        if np.hypot(press.pos[0] - first[0], press.pos[1] - first[1]) <= CLOSE_RADIUS:
            close_patch(app)
            return
    if not st.draft:
        pair = pair_at(app, press.xy)
        if pair is None:
            app.say(f"start a patch where {overlap_hint(app)} overlap", "error")
            return
        st.draft_pair, st.draft_screen = pair[:2], []
    k = app.layer_index(st.draft_pair[0])
    rest = pick.rest_point(app.snap.layers[k], press.xy) if k is not None else None
    if rest is None:
        app.say(f"a patch corner must lie on layer {st.draft_pair[0]}", "error")
        return
    st.draft.append(rest)
    st.draft_screen.append(tuple(press.xy))
    app.say(f"patch: {len(st.draft)} points (click the first point to close it)")


def close_patch(app) -> None:
    """Add the drafted polygon as a link polygon (needs 3 points)."""
    st = state(app)
    pts, pair = list(st.draft), st.draft_pair
    cancel_patch(app)
    if len(pts) < 3 or pair is None:
        app.say("a patch needs at least 3 points", "error")
        return
    a, b = pair
    st.link = (a, b)
    app.edit(lambda s: s.add_link_polygon(a, b, pts))


def cancel_patch(app) -> None:
    st = state(app)
    st.draft, st.draft_screen, st.draft_pair = [], [], None


# -- the heat map's grey levels ---------------------------------------------------------------
def vertex_grey(app, k: int) -> np.ndarray | None:
    """Stiffness (grey 0..255) the solver sees at layer ``k``'s vertices: the painted image,
    starch pins and link polygons (:func:`puppet.scene.rig.stiffness.layer_grey`); cached while
    the scene data (and the mesh) stay the same."""
    snap, st = app.snap, state(app)
    rest = np.asarray(snap.layers[k].rest, float)
    hit = st.heat.get(k)
    if hit is None or hit[0] is not snap.data or hit[1] != len(rest):
        try:
            g = layer_grey(snap.data, k, snap.images[k], rest)
        except SceneError:
            g = None
        hit = st.heat[k] = (snap.data, len(rest), g)
    return hit[2]
