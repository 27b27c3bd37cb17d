"""The task script (the layered-deformation paper's workflow, §4): Image -> Layers -> Link
-> Pins -> Deform -> Pose, as a bar of step buttons. Each step chooses the canvas tool
and the panel that make sense; any step can be revisited (the scene re-meshes only what
an edit touched, so later steps keep working).

- Image: the first layer's mask: alpha, a brightness threshold (slider), GrabCut from a
  dragged rectangle, brush add / subtract.
- Layers: + / - layers; the lasso, rectangle and clone brush make a Layer via Cut or Copy of
  the selected layer, or clone from the picture into it; erase,
  repaint with a colour, inpainting method with a before / after preview.
- Link: two layers, their mask intersection tinted, a pencil for link segments (the part
  of a segment inside the intersection is kept, shown while it drags).
- Pins: the Pin tool, plus automatic exterior points (beta slider, live).
- Link and Pins: "Rig automatically" proposes the anatomy rig, drawn before it is accepted.
- Deform: meshes built and shown, Pose mode.
"""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui

from puppet.app.model.steps import LABELS, SELECT_OPS, STEPS, TIPS, TOOLS, set_step
from puppet.app.tools import autorig
from puppet.app.tools import mask as masktools
from puppet.app.tools.dispatch import step_tool
from puppet.app.ui.overlay import draw_link_preview, draw_rig_proposal
from puppet.app.ui.widgets import RECTS, button, live, note
from puppet.scene.format.model import INPAINT_METHODS

#: the inpainting preview, in thumbnail sizes
PREVIEW = 3.0


def bar(app) -> None:
    """The step buttons (in the toolbar)."""
    for k, step in enumerate(STEPS):
        active = app.script.step == step
        if active:
            imgui.push_style_color(imgui.Col_.button, imgui.ImVec4(0.75, 0.45, 0.1, 1.0))
        if button(f"{k + 1}. {LABELS[step]}" if step != "pose" else LABELS[step], TIPS[step], enabled=app.snap.loaded):
            app.say(f"{LABELS[step]}: {TIPS[step]}")  # not the last step's message (the Image step's, in Layers)
            set_step(app, step)
        note(f"step:{step}")
        if active:
            imgui.pop_style_color()
        imgui.same_line()


def panel(app, thumbs) -> None:
    """The current step's panel (above the others)."""
    sc = app.script
    if sc.step == "pose" or not app.snap.loaded:
        return
    imgui.text(f"Step: {LABELS[sc.step]}")
    if sc.step in ("image", "layers", "link"):
        imgui.same_line()
        _, sc.show_tint = imgui.checkbox("tint", sc.show_tint)
        imgui.set_item_tooltip("tint the selected layer's mask (Link: the two layers' intersection)")
        note("check:tint")
    imgui.text_wrapped(TIPS[sc.step])
    for j, (tool, label, tip) in enumerate(TOOLS.get(sc.step, [])):
        if j % 3:
            imgui.same_line()
        if imgui.radio_button(f"{label}##tool", sc.tool == tool):
            sc.tool = tool
        imgui.set_item_tooltip(tip)
        note(f"tool:{tool}")
    if sc.step in ("image", "layers"):
        _, sc.brush = imgui.slider_float("brush size", sc.brush, 1.0, 120.0, "%.0f px")
        imgui.set_item_tooltip("brush diameter in picture pixels")
        note("slider:brush size")
    {"image": _image, "layers": _layers, "link": _link, "pins": _pins, "deform": _deform}[sc.step](app, thumbs)
    imgui.separator()


def _image(app, thumbs) -> None:
    sc, snap = app.script, app.snap
    name = snap.data.layers[0].name
    imgui.text(f"mask of {name}:")
    imgui.same_line()
    if button("Alpha", "the picture's transparency"):
        app.edit(lambda s: s.set_mask(name, "alpha"))
    changed, sc.threshold = imgui.slider_float("threshold", sc.threshold, 1.0, 255.0, "%.0f")
    imgui.set_item_tooltip("pixels darker than this are the object (live)")
    note("slider:threshold")
    a = imgui.get_item_rect_min()
    RECTS["frame:threshold"] = (a.x, a.y, a.x + imgui.calc_item_width(), imgui.get_item_rect_max().y)
    live(app, "threshold", f"threshold mask of {name}")
    if changed:
        app.edit(lambda s, t=float(sc.threshold): s.set_mask(name, {"threshold": t}), key="threshold-live")


def _layers(app, thumbs) -> None:
    sc, snap = app.script, app.snap
    if sc.select_after is not None and app.layer_index(sc.select_after) is not None:
        app.selected_layer, sc.select_after = sc.select_after, None  # made by a cut / copy
    if button("+", "a new empty layer in front: clone pixels into it"):
        sc.pending = None  # a second + replaces the empty layer: its name is free again
        sc.pending = sc.free_name(app)
        app.selected_layer = sc.pending
        sc.tool = "lasso"
        app.say(f"new layer {sc.pending}: clone pixels into it (lasso, rectangle or brush)")
    imgui.same_line()
    target = sc.target_layer(app)
    if button("-", "remove the selected layer", enabled=target is not None):
        if target == sc.pending:
            sc.pending = None
            app.selected_layer = None
        else:
            app.edit(lambda s: s.remove_layer(target))
    imgui.same_line()
    imgui.text(f"layer: {target or '(none)'}" + ("  (empty)" if target is not None and target == sc.pending else ""))
    if sc.pending is not None and app.layer_index(sc.pending) is not None:
        sc.pending = None  # it has pixels now
    imgui.set_next_item_width(150)
    enter, sc.layer_name = imgui.input_text_with_hint("##layer-name", target or "", sc.layer_name,
                                                     imgui.InputTextFlags_.enter_returns_true)
    imgui.set_item_tooltip("type a new name for the layer and press Enter")
    note("field:layer name")
    new = sc.layer_name.strip()
    if enter and new and target is not None and new != target:
        if target == sc.pending:
            sc.pending = app.selected_layer = new
        else:
            app.edit(lambda s: s.rename_layer(target, new))
            app.selected_layer = new
        sc.layer_name = ""
    if sc.tool in ("lasso", "clone-rect", "clone-brush") and target != sc.pending:
        for j, (op, label, tip) in enumerate(SELECT_OPS):
            if j == 1:
                imgui.same_line()
            if imgui.radio_button(f"{label}##select", sc.select_op == op):
                sc.select_op = op
            imgui.set_item_tooltip(tip)
            note(f"select:{op}")
    if sc.tool == "paint":
        _, sc.color = imgui.color_edit4("colour", list(sc.color), imgui.ColorEditFlags_.no_alpha)
        imgui.set_item_tooltip("the Paint tool's colour")
    k = app.layer_index(target)
    if k is not None and snap.images[k].from_source:
        imgui.text("refill:")
        cur = snap.data.layers[k].inpaint
        for j, m in enumerate(INPAINT_METHODS):
            if j != 3:
                imgui.same_line()
            if imgui.radio_button(f"{m}##inpaint", cur == m) and m != cur:
                app.edit(lambda s, m=m: s.set_inpaint(target, m))
            imgui.set_item_tooltip("how this layer refills what layers in front took from the picture")
            note(f"inpaint:{m}")
        _inpaint_preview(app, thumbs, k)


def _inpaint_preview(app, thumbs, k) -> None:
    """Before (the picture) / after (the layer, refilled) over the area that layers in
    front took from the picture."""
    snap = app.snap
    im = snap.images[k]
    front = np.zeros(im.mask.shape, bool)
    for j, other in enumerate(snap.images):
        if j != k and other.from_source and snap.rank[j] > snap.rank[k]:
            front |= other.mask
    area = front & im.mask
    if not area.any():
        return
    ys, xs = np.nonzero(area)
    y0, y1, x0, x1 = max(ys.min() - 4, 0), ys.max() + 5, max(xs.min() - 4, 0), xs.max() + 5
    after = np.ascontiguousarray(im.rgba[y0:y1, x0:x1])
    src = app.script.source(app)
    before = None if src is None else np.ascontiguousarray(src[y0:y1, x0:x1])
    imgui.text("refilled area (inpaint):")
    if before is not None:
        ref, size = thumbs.ref(f"before-{y0}-{y1}-{x0}-{x1}", before)
        imgui.image(ref, imgui.ImVec2(size[0] * PREVIEW, size[1] * PREVIEW))
        imgui.set_item_tooltip("before: the picture")
        imgui.same_line()
    ref, size = thumbs.ref(f"after-{snap.image_keys[k]}-{y0}-{y1}-{x0}-{x1}", after)
    imgui.image(ref, imgui.ImVec2(size[0] * PREVIEW, size[1] * PREVIEW))
    imgui.set_item_tooltip("after: this layer, refilled")
    note("inpaint:after")


def _autorig(app) -> None:
    """"Rig automatically": propose, then Accept (one undo step) or Discard."""
    if button("Rig automatically", "propose hinges where limbs join the torso or their parent limb, glue for parts "
              "painted on others, and pins at the torso, shoulders, hips and free ends (drawn in magenta first; "
              "layers already pinned or linked keep their rig)", enabled=not app.busy):
        autorig.propose(app)
    p = autorig.current(app)
    if p is not None and (p.pins or p.links):
        imgui.same_line()
        if button("Accept", "add the proposed pins and links (one undo step)"):
            autorig.accept(app)
        imgui.same_line()
        if button("Discard", "drop the proposal"):
            autorig.discard(app)
    imgui.separator()


def _link(app, thumbs) -> None:
    _autorig(app)
    sc, snap = app.script, app.snap
    names = [L.name for L in snap.data.layers]
    a, b = sc.link_pair(app)
    for attr, cur, label in (("link_a", a, "layer A"), ("link_b", b, "layer B")):
        i = names.index(cur) if cur in names else 0
        imgui.set_next_item_width(150)
        changed, i = imgui.combo(label, i, names)
        imgui.set_item_tooltip("the two layers to link")
        if changed:
            setattr(sc, attr, names[i])
            sc.link_preview = None
    imgui.text("links:")
    for L in snap.data.links:
        for kind, j, text in link_parts(L):
            la, lb = L.layers
            imgui.push_id(f"link-{la}-{lb}-{kind}-{j}")
            if button("x", f"remove this {text.split(' ')[0]}", small=True):
                app.edit(lambda s, la=la, lb=lb, kind=kind, j=j: s.remove_link_part(la, lb, kind, j))
            note(f"remove-link:{la}-{lb}:{kind}:{j}")
            imgui.same_line()
            imgui.text(f"{la}-{lb}: {text}")
            imgui.pop_id()


def link_parts(link) -> list[tuple[str, int, str]]:
    """(kind, index, label) of every part of ``link``: its segments, hinges and patches."""
    out = [("segments", j, f"segment ({x0:.0f},{y0:.0f})-({x1:.0f},{y1:.0f})")
           for j, ((x0, y0), (x1, y1)) in enumerate(link.segments)]
    out += [("points", j, f"hinge ({q[0]:.0f},{q[1]:.0f})") for j, q in enumerate(link.points)]
    out += [("polygons", j, f"patch of {len(P)} corners at ({np.mean(P, axis=0)[0]:.0f},{np.mean(P, axis=0)[1]:.0f})")
            for j, P in enumerate(link.polygons)]
    return out


def _pins(app, thumbs) -> None:
    _autorig(app)
    sc, snap = app.script, app.snap
    name = app.selected_layer or snap.data.layers[-1].name
    k = app.layer_index(name)
    if k is None:
        return
    L = snap.data.layers[k]
    auto = L.exterior is not None and bool(getattr(L.exterior, "auto", False))
    changed, on = imgui.checkbox(f"exterior points of {name}", auto)
    imgui.set_item_tooltip("automatic exterior control points where the outline bends (curvature scale space)")
    note("check:exterior")
    if changed:
        app.edit(lambda s, b=float(sc.beta): s.set_layer(name, exterior={"auto": True, "beta": b} if on else None))
    if auto:
        sc.beta = float(L.exterior.beta) if not imgui.is_any_item_active() else sc.beta
        changed, sc.beta = imgui.slider_float("beta", sc.beta, 0.2, 8.0, "%.2f", imgui.SliderFlags_.logarithmic)
        imgui.set_item_tooltip("more points with a higher beta (finer curvature scale); the points show live")
        note("slider:beta")
        live(app, "beta", f"exterior beta of {name}")
        if changed:
            app.edit(lambda s, b=float(sc.beta): s.set_layer(name, exterior={"auto": True, "beta": b}),
                     key="beta-live")
    imgui.text_wrapped("click to add a pin on the layer you see there; new pins' kind below")


def _deform(app, thumbs) -> None:
    if app.busy:
        imgui.text("building meshes" + "." * (int(imgui.get_time() * 3) % 4))
    else:
        imgui.text_wrapped("meshes built: drag a pin to pose (a new pose is made at the first drag)")


# -- canvas overlay ----------------------------------------------------------------------------
def draw_overlay(dl, app) -> None:
    """Drafts of the gesture in progress and the link segment drawn (what it keeps)."""
    sc = app.script
    col = imgui.get_color_u32
    if sc.draft and len(sc.draft) >= 1:
        pts = [tuple(map(float, app.view.to_screen(p))) for p in sc.draft]
        c = col(imgui.ImVec4(1.0, 0.9, 0.2, 1.0))
        if sc.draft_kind == "rect":
            dl.add_rect(imgui.ImVec2(*pts[0]), imgui.ImVec2(*pts[-1]), c, 0.0, 2.0)
        else:
            w = sc.brush * app.view.scale if sc.draft_kind == "brush" else 2.0
            for p, q in zip(pts, pts[1:]):
                dl.add_line(imgui.ImVec2(*p), imgui.ImVec2(*q), c, max(w, 1.0) if sc.draft_kind == "brush" else 2.0)
            if sc.draft_kind == "lasso" and len(pts) > 2:
                dl.add_line(imgui.ImVec2(*pts[-1]), imgui.ImVec2(*pts[0]), c, 1.0)
    if sc.draft is None and sc.step in TOOLS and step_tool(app) is masktools.brush_tool \
            and imgui.is_window_hovered():  # the brush's size under the pointer
        m = imgui.get_io().mouse_pos
        dl.add_circle(imgui.ImVec2(m.x, m.y), max(sc.brush / 2 * app.view.scale, 2.0),
                      col(imgui.ImVec4(1.0, 1.0, 1.0, 0.8)), 0, 1.5)
    if sc.step == "link":
        draw_link_preview(dl, app)
    if sc.step in ("link", "pins"):
        draw_rig_proposal(dl, app)
