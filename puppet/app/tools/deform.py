"""Canvas tools of the deformation that fits real art (issue 22): the stiffness brush
(paints grey 0..255 into a layer's stiffness image, Alt erases), the hinge tool (a click
in the overlap of two layers adds a link point), the patch tool (clicks make a polygon,
a click on its first point closes it into a link polygon), the cage tool (makes, edits
and removes a layer's ``layers[i].cage``: in Pin mode a click on a cage edge adds a
vertex, a drag moves one, a right click or Delete deletes one; in Pose mode the handles
``LAYER:cageN`` drag like pins, by the mode's own tools), and the grey levels of the
stiffness heat map (drawn by :mod:`puppet.app.ui.deform_overlay`). The Deform panel (:mod:`puppet.app.ui.deform_panel`) chooses the tool.

Each stroke, hinge or patch is one edit on the scene thread, so one undo step. Points
are taken back to the rest pose through the shown mesh, so the tools work in a pose too.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from puppet.app.model import pick
from puppet.app.tools import chains as chaintools
from puppet.app.tools import mask as masktools
from puppet.app.tools.gestures import click_or_drag, delta, moved
from puppet.deform.cage import check_cage
from puppet.errors import SceneError
from puppet.imaging.masks import canvas_to_image
from puppet.scene.rig.stiffness import layer_grey, stiffness_image

#: a click this close to a patch's first point (window pixels) closes the patch
CLOSE_RADIUS = 9.0
TOOLS = ("stiffness", "hinge", "patch", "cage", "chain")
#: window pixels within which a press picks a cage vertex, and then a cage edge
CAGE_RADIUS, EDGE_RADIUS = 9.0, 6.0
#: the automatic cage "Make cage" asks for at first: vertices, offset (canvas px)
CAGE_AUTO, CAGE_OFFSET = 12, 10.0
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
    cage_auto: int = CAGE_AUTO  # "Make cage": about this many vertices
    cage_offset: float = CAGE_OFFSET  # ... this far (canvas px) outside the layer's mask
    cage_drag: tuple | None = None  # a cage vertex drag's preview: (layer, cage (m, 2) canvas xy, job or None)
    cage_crossed: tuple = (None, None, False)  # cache of cage_crossed: (snapshot, layer index, answer)
    chain_draft: list = field(default_factory=list)  # the chain tool's pins so far, anchor first
    chain: int | None = None  # the selected chain (index into physics.chains)


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
    if t in ("cage", "chain") and app.mode != "pin":
        return None  # in Pose mode cage handles drag like pins (the pose and animation tools)
    if t == "chain":
        return lambda app, press: chaintools.chain_tool(app, state(app), press)
    return {"stiffness": stiffness_tool, "hinge": hinge_tool, "patch": patch_tool, "cage": cage_tool}.get(t)


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


# -- the cage tool ---------------------------------------------------------------------
def handle(layer: str, j: int) -> str:
    """The name of cage vertex ``j`` of ``layer`` as a pose handle."""
    return f"{layer}:cage{j}"


def cage_crossed(app, k: int) -> bool:
    """Does layer ``k``'s posed cage cross itself? (Landmarks that ask a ``green`` cage
    for a change of proportions are met by bending: its vertices, the coefficients of a
    conformal map, then leave the garment and cross; the Deform panel says so.) Cached
    per snapshot: the check is quadratic in the cage's vertices."""
    st = state(app)
    if st.cage_crossed[:2] != (app.snap, k):
        C = shown_cage(app, k)
        st.cage_crossed = (app.snap, k, C is not None and check_cage(C) is not None)
    return st.cage_crossed[2]


def cage_handle_of(app, name: str) -> tuple[str, int] | None:
    """(layer, vertex index) when ``name`` is a caged layer's handle ``LAYER:cageN``."""
    layer, _, j = name.rpartition(":cage")
    k = app.layer_index(layer) if layer and j.isdigit() else None
    return (layer, int(j)) if k is not None and app.snap.data.layers[k].cage is not None else None


def cages_drawn(app) -> bool:
    """The cages are drawn over their layers (the cage tool is on, or View > Cages):
    their vertices are then drawn as the cage's squares, not as pin markers."""
    return bool(getattr(app, "show_cages", False)) or state(app).tool == "cage"


def shown_cage(app, k: int) -> np.ndarray | None:
    """Layer ``k``'s cage (m, 2) as shown (canvas xy: the rest cage in Pin mode, the posed
    one in Pose mode, handles being dragged where the pointer has them); None when the
    layer has no cage."""
    L = app.snap.data.layers[k]
    if L.cage is None or k >= len(app.snap.layers):
        return None
    ext, pts = app.snap.layers[k].exterior, []
    while (n := handle(L.name, len(pts))) in ext:
        pts.append(app.overrides.get(n, ext[n]))
    return np.asarray(pts, float).reshape(-1, 2) if len(pts) >= 3 else None


def cages(app) -> list[tuple[str, np.ndarray]]:
    """(layer name, shown cage) of every visible caged layer."""
    hidden = app.hidden_indices()
    out = []
    for k, L in enumerate(app.snap.data.layers):
        C = shown_cage(app, k) if k not in hidden else None
        if C is not None:
            out.append((L.name, C))
    return out


def cage_at(app, pos) -> tuple[str, str, int, np.ndarray] | None:
    """What of a cage is at window point ``pos``: ("vertex", layer, j, vertex) for the
    nearest vertex within :data:`CAGE_RADIUS`, else ("edge", layer, j, point) for the
    nearest point of edge j (vertex j to j + 1) within :data:`EDGE_RADIUS`; None."""
    P = np.asarray(pos, float)
    found = [(layer, C, np.asarray(app.view.to_screen(C), float)) for layer, C in cages(app)]
    near = [(float(np.hypot(*(S - P).T).min()), layer, int(np.argmin(np.hypot(*(S - P).T))), C)
            for layer, C, S in found]
    best = min(near, key=lambda c: c[0], default=None)
    if best is not None and best[0] <= CAGE_RADIUS:
        return "vertex", best[1], best[2], best[3][best[2]]
    edges = []
    for layer, C, S in found:
        A, AB = S, np.roll(S, -1, axis=0) - S
        t = np.clip(((P - A) * AB).sum(1) / np.maximum((AB * AB).sum(1), 1e-12), 0.0, 1.0)
        d = np.hypot(*(A + t[:, None] * AB - P).T)
        j = int(np.argmin(d))
        edges.append((float(d[j]), layer, j, C[j] + t[j] * (np.roll(C, -1, axis=0)[j] - C[j])))
    best = min(edges, key=lambda c: c[0], default=None)
    return ("edge", *best[1:]) if best is not None and best[0] <= EDGE_RADIUS else None


def cage_value(cage, points=None, coordinates: str | None = None) -> dict:
    """The scene-format value of ``cage`` (a :class:`~puppet.scene.format.model.Cage`)
    with its ``points`` and ``coordinates`` replaced where given; an automatic cage keeps
    its ``auto`` and ``offset`` (they then only say how it was made)."""
    out: dict = {} if cage.auto is None else {"auto": int(cage.auto), "offset": float(cage.offset)}
    pts = cage.points if points is None else points
    if pts is not None:
        out["points"] = [[float(x), float(y)] for x, y in np.asarray(pts, float)]
    out["coordinates"] = coordinates or cage.coordinates
    return out


def set_cage(app, layer: str, value, done: str, vertices=None) -> int:
    """Give ``layer`` the cage ``value`` (None: remove it), one undo step; the status line
    says ``done``, or the scene's one-line refusal (the cage then stays as it was).
    ``vertices``: per new point, the old vertex it is (None: added), so handle targets in
    poses and keys follow their vertex (``Document.set_cage``)."""
    def fn(s):
        s.set_cage(layer, value, vertices=vertices)
        return done
    return app.edit(fn)


def make_cage(app, layer: str) -> int:
    """An automatic cage around ``layer`` (the panel's vertices and offset; the layer's
    coordinates kind, green for a layer without a cage)."""
    st, k = state(app), app.layer_index(layer)
    old = app.snap.data.layers[k].cage if k is not None else None
    value = {"auto": int(st.cage_auto), "offset": float(st.cage_offset),
             "coordinates": old.coordinates if old is not None else "green"}
    return set_cage(app, layer, value, f"{layer}: a cage of about {st.cage_auto} vertices, "
                                       f"{st.cage_offset:g} px out")


def set_points(app, layer: str, points, done: str, vertices=None) -> int | None:
    """Replace ``layer``'s cage points (its kind and ``auto`` stay); ``vertices`` as
    :func:`set_cage`'s."""
    k = app.layer_index(layer)
    cage = app.snap.data.layers[k].cage if k is not None else None
    if cage is None:
        return None
    return set_cage(app, layer, cage_value(cage, points), done, vertices)


def delete_vertex(app, layer: str, j: int) -> None:
    """Delete vertex ``j`` of ``layer``'s cage (a cage keeps at least 3)."""
    C = shown_cage(app, app.layer_index(layer))
    if C is None or j >= len(C):
        return
    if len(C) <= 3:
        app.say(f"the cage of {layer} has 3 vertices, the fewest a cage can have", "error")
        return
    app.selection = [n for n in app.selection if n != handle(layer, j)]
    set_points(app, layer, np.delete(C, j, axis=0), f"{layer}: deleted cage vertex {j}",
               [i for i in range(len(C)) if i != j])


def delete_selected(app) -> bool:
    """Delete (the key) with the cage tool on in Pin mode: delete the selected cage vertex
    (the first one selected); False when no cage vertex is selected there."""
    if sync(app) != "cage" or app.mode != "pin":
        return False
    for name in app.selection:
        h = cage_handle_of(app, name)
        if h is not None:
            delete_vertex(app, *h)
            return True
    return False


def cage_tool(app, press):
    """Pin mode: a click on a cage edge adds a vertex there, a drag of a vertex moves it,
    a right click on a vertex deletes it (each one undo step). (In Pose mode the mode's
    tools run: :func:`canvas_tool`.)"""
    hit = cage_at(app, press.pos)
    if hit is None:
        _, went = yield from click_or_drag(press)
        if not went:
            app.say("cage: click a cage edge to add a vertex, drag a vertex to move it, right-click it to delete "
                    "it (Make cage in the Deform panel makes one)")
        return
    kind, layer, j, at = hit
    app.selected_layer = layer
    C = shown_cage(app, app.layer_index(layer))
    if kind == "edge":
        _, went = yield from click_or_drag(press)
        if not went and press.button == 0:
            app.selection = [handle(layer, j + 1)]
            set_points(app, layer, np.insert(C, j + 1, at, axis=0), f"{layer}: added cage vertex {j + 1}",
                       [*range(j + 1), None, *range(j + 1, len(C))])
        return
    app.selection = [handle(layer, j)]
    if press.button != 0:
        _, went = yield from click_or_drag(press)
        if not went:
            delete_vertex(app, layer, j)
        return
    yield from drag_vertex(app, press, layer, C, j)


def drag_vertex(app, press, layer: str, C: np.ndarray, j: int):
    """Drag vertex ``j`` of ``layer``'s cage ``C``: the moved cage is previewed while
    dragging and set on the release (shown until that edit's snapshot arrives)."""
    st, ev, went = state(app), press, False
    while ev.type != "release":
        ev = yield
        went = went or moved(ev, press)
        if went:
            P = C.copy()
            P[j] = C[j] + delta(app, ev, press)
            st.cage_drag = (layer, P, None)
    if went:
        job = set_points(app, layer, st.cage_drag[1], f"{layer}: moved cage vertex {j}")
        st.cage_drag = (layer, st.cage_drag[1], job)


def cage_preview(app) -> tuple[str, np.ndarray] | None:
    """The cage a vertex drag shows (until the snapshot of its edit arrives, or the scene
    thread is idle with its last snapshot shown: the edit was refused)."""
    d, session = state(app).cage_drag, app.session
    ended = d is not None and d[2] is not None and (app.snap.done >= d[2] or (session.idle()
                                                                          and session.latest is app.snap))
    if ended:
        state(app).cage_drag = d = None
    if d is None:
        return None
    return d[0], d[1]


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
