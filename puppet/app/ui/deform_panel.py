"""The Deform panel (issue 22): the scene's deformation mode and the selected layer's,
the tools of :mod:`puppet.app.tools.deform` (stiffness brush, hinge, patch, cage) with the
cage tool's controls (make, coordinates, remove), the heat map,
starch pins and their radius, and the selected link's strength."""
from __future__ import annotations

from imgui_bundle import imgui

from puppet.app.tools import chains as chaintools
from puppet.app.tools import deform as deformtools
from puppet.app.ui.widgets import button, live, note, toggle
from puppet.scene.format.model import CAGE_KINDS, MODES
from puppet.scene.rig.stiffness import STARCH_RADIUS

MODE_TIPS = {
    "rigid": "as-rigid-as-possible: parts bend but keep their size (the default)",
    "similar": "as-similar-as-possible: parts may grow or shrink evenly (fitting a garment to a smaller body)",
    "distort": "stretchy: parts may stretch and shear (an affine fit per cell)",
}
TOOL_LABELS = (("none", None, "the mode's own tool (pins)"),
               ("brush", "stiffness", "paint stiffness into the layer (Alt: erase); one undo step a stroke"),
               ("hinge", "hinge", "click where two layers overlap: they share a point and turn about it"),
               ("patch", "patch", "click the corners of a shared patch; click the first point to close it"),
               ("cage", "cage", "the selected layer's cage: Pin mode: click an edge to add a vertex, drag one to "
                                "move it, right-click (or Delete) to delete it; Pose mode: drag its vertices"),
               ("chain", "chain", "secondary motion: in Pin mode click a chain's pins, anchor first, and the last "
                                  "one again to make it; it swings, lags and settles in the playback"))
CAGE_TIPS = {"green": "Green coordinates: conformal, a pattern keeps its angles (exact for similarities)",
             "mvc": "mean value coordinates: exact for affine maps of the cage",
             "harmonic": "harmonic coordinates: non-negative, shape-aware, exact for affine maps (slower to set up)"}


def link_step_tools(app) -> None:
    """The hinge and patch tools again under the Link step's pencil (the Deform panel is
    below the fold at 1280x800 in that step: a first user scrolled, opened it and scrolled
    again to find the hinge)."""
    st = deformtools.state(app)
    deformtools.sync(app)
    imgui.text("or:")
    for label, tool, tip in TOOL_LABELS[2:4]:  # hinge, patch
        imgui.same_line()
        if imgui.radio_button(f"{label.capitalize()}##link-step", st.tool == tool):
            deformtools.choose(app, tool)
            app.say(f"{label}: {tip}")
        imgui.set_item_tooltip(tip + " (also in the Deform panel)")
        note(f"link-step:{label}")
    imgui.separator()


def panel(app) -> None:
    """Draw the Deform panel's contents (under its collapsing header)."""
    snap, st = app.snap, deformtools.state(app)
    deformtools.sync(app)
    modes(app)
    imgui.separator()
    imgui.text("tool:")
    for label, tool, tip in TOOL_LABELS:
        if tool not in ("cage", "chain"):  # the cage and the chain on a line of their own: the panel is narrow
            imgui.same_line()
        elif tool == "chain":
            imgui.same_line()
        if imgui.radio_button(f"{label}##deform-tool", st.tool == tool):
            deformtools.choose(app, tool)
            app.say(f"{label}: {tip}")
        imgui.set_item_tooltip(tip)
        note(f"deform-tool:{label}")
    if st.tool == "stiffness":
        _, st.brush = imgui.slider_float("brush size##stiffness", st.brush, 2.0, 300.0, "%.0f px",
                                         imgui.SliderFlags_.logarithmic)
        imgui.set_item_tooltip("the stiffness brush's diameter, canvas pixels")
        note("slider:stiffness brush")
        pct = int(round(st.value * 100 / 255))
        changed, pct = imgui.slider_int("strength##stiffness", pct, 0, 100, "%d %%")
        if changed:
            st.value = int(round(pct * 255 / 100))
        imgui.set_item_tooltip("how much the painted part resists the pins: 0 % normal, 100 % rigid (it then "
                               "keeps its size even in a similar fit); Alt-drag erases to 0 %")
        note("slider:stiffness value")
        k = app.layer_index(app.selected_layer)
        if button("Clear stiffness", "remove the selected layer's painted stiffness",
                  enabled=k is not None and snap.data.layers[k].stiffness is not None):
            name = app.selected_layer
            app.edit(lambda s: s.set_layer(name, stiffness=None))
    if st.tool == "cage":
        cage(app)
    if st.tool == "chain":
        chain(app)
    if st.tool == "patch" and st.draft:
        if button("Close patch", "the drafted polygon becomes a shared patch", enabled=len(st.draft) >= 3):
            deformtools.close_patch(app)
        imgui.same_line()
        if button("Cancel patch", "forget the drafted points"):
            deformtools.cancel_patch(app)
    app.show_stiffness = toggle("stiffness heat map", getattr(app, "show_stiffness", False),
                                "draw the stiffness the solver sees (paint, starch pins, patches) in red")
    imgui.separator()
    starch(app)
    imgui.separator()
    links(app)


def modes(app) -> None:
    """The scene's mode and the selected layer's (or "scene default")."""
    snap = app.snap
    cur = snap.data.deformer.mode
    imgui.set_next_item_width(140)
    i = combo("scene mode", "scene mode", list(MODES), MODES.index(cur),
              "\n".join(f"{m}: {MODE_TIPS[m]}" for m in MODES))
    if i is not None:
        m = MODES[i]
        app.edit(lambda s: s.set_deformer(mode=m))
    k = app.layer_index(app.selected_layer)
    if k is None:
        imgui.text_disabled("select a layer for its own mode")
        return
    L = snap.data.layers[k]
    items = ["scene default"] + list(MODES)
    imgui.set_next_item_width(140)
    i = combo(f"{L.name} mode", "layer mode", items, items.index(L.mode or "scene default"),
              "this layer's deformation mode (overrides the scene's)")
    if i is not None:
        value = None if i == 0 else {"mode": items[i]}
        name = L.name
        app.edit(lambda s: s.set_layer(name, deformer=value))


def cage(app) -> None:
    """The cage tool's controls for the selected layer: Make cage (an automatic cage of
    about N vertices, PX out), its coordinates, Remove cage."""
    st, k = deformtools.state(app), app.layer_index(app.selected_layer)
    if k is None:
        imgui.text_disabled("select a layer for its cage")
        return
    L = app.snap.data.layers[k]
    imgui.set_next_item_width(100)
    _, n = imgui.input_int("vertices##cage", st.cage_auto, 0)
    imgui.set_item_tooltip("Make cage: about this many cage vertices (3 to 1000)")
    note("input:cage vertices")
    st.cage_auto = min(max(int(n), 3), 1000)
    imgui.same_line()
    imgui.set_next_item_width(100)
    _, off = imgui.input_float("offset##cage", st.cage_offset, 0.0, 0.0, "%.0f px")
    imgui.set_item_tooltip("Make cage: how far (canvas px) the cage keeps outside the layer")
    note("input:cage offset")
    st.cage_offset = min(max(float(off), 0.0), 1000.0)
    if button("Make cage", f"an automatic cage around {L.name} (replaces its cage; one undo step)"):
        deformtools.make_cage(app, L.name)
    if L.cage is None:
        imgui.same_line()
        imgui.text_disabled(f"{L.name} has no cage")
        return
    imgui.same_line()
    if button("Remove cage", f"{L.name} is deformed by the pins again (its cage handles leave the poses)"):
        name = L.name
        deformtools.set_cage(app, name, None, f"{name}: cage removed")
    imgui.set_next_item_width(140)
    i = combo("coordinates", "cage coordinates", list(CAGE_KINDS), CAGE_KINDS.index(L.cage.coordinates),
              "\n".join(f"{c}: {CAGE_TIPS[c]}" for c in CAGE_KINDS))
    if i is not None:
        name, kind = L.name, CAGE_KINDS[i]
        deformtools.set_cage(app, name, deformtools.cage_value(L.cage, coordinates=kind),
                             f"{name}: {kind} coordinates")
    if L.cage.coordinates == "green" and app.mode == "pose" and deformtools.cage_crossed(app, k):
        imgui.text_wrapped("green keeps angles, so this pose's change of proportions is met by bending: the cage "
                           "leaves the layer and crosses itself (it is a conformal map's coefficients). mvc or "
                           "harmonic stretch instead.")
        note("cage:green bends")


CHAIN_SLIDERS = (("frequency", 0.1, 10.0, "%.2f Hz", "how fast each link swings back (Hz): low is slow and "
                                                     "floppy, high is tight"),
                 ("damping", 0.0, 2.0, "%.2f", "how soon the swing dies: 0 never, 0.3 after a few swings, "
                                               "1 without overshoot"),
                 ("gravity", -3000.0, 3000.0, "%.0f px/s2", "pull along +y (down on screen); 0: the chain "
                                                             "settles on its animated pose"))


def chain(app) -> None:
    """The chain tool's controls: the draft (Make chain, Cancel), the scene's chains (select
    one), the selected chain's sliders and Remove chain."""
    st, data = deformtools.state(app), app.snap.data
    if st.chain_draft:
        imgui.text_wrapped("new chain: " + " > ".join(st.chain_draft))
        if button("Make chain", "make the drafted chain (2 pins or more; or click its last pin again)",
                  enabled=len(st.chain_draft) >= 2):
            chaintools.finish(app, st)
        imgui.same_line()
        if button("Cancel##chain", "forget the drafted chain (Esc)"):
            chaintools.cancel(app, st)
    elif not data.chains:
        imgui.text_disabled("no chains: in Pin mode click a chain's anchor pin, then the pins that hang from it")
    for i, ch in enumerate(data.chains):
        clicked, _ = imgui.selectable(f"{' > '.join(ch.pins)}##chain-{i}", st.chain == i)
        note(f"chain:{i}")
        if clicked:
            st.chain = i
    if st.chain is None or st.chain >= len(data.chains):
        return
    ch = data.chains[st.chain]
    for field, lo, hi, fmt, tip in CHAIN_SLIDERS:
        flags = imgui.SliderFlags_.logarithmic if field == "frequency" else 0
        changed, v = imgui.slider_float(f"{field}##chain", getattr(ch, field), lo, hi, fmt, flags)
        imgui.set_item_tooltip(tip)
        note(f"slider:chain {field}")
        live(app, "chain", f"chain {field}")
        if changed:
            chaintools.set_field(app, st.chain, field, v)
    if button("Remove chain", "the chain's pins stop swinging (the pins stay)"):
        chaintools.remove(app, st, st.chain)


def combo(label: str, key: str, items, current: int, tip: str) -> int | None:
    """A combo box whose items are noted as ``key:item`` (tests click them); the chosen
    index when it changed, else None."""
    out = None
    opened = imgui.begin_combo(label, items[current])
    imgui.set_item_tooltip(tip)
    note(f"combo:{key}")
    if opened:
        for i, item in enumerate(items):
            clicked, _ = imgui.selectable(f"{item}##{key}", i == current)
            note(f"{key}:{item}")
            if clicked and i != current:
                out = i
        imgui.end_combo()
    return out


def starch(app) -> None:
    """Starch pins: the Pin tool's kind, and the selected starch pin's radius."""
    on = app.pin_kind == "starch"
    new = toggle("new pins are starch", on, "Pin mode: a click adds a starch pin, which stiffens the region "
                                            "around it and holds no position (not draggable in poses)")
    if new != on:
        app.pin_kind = "starch" if new else "interior"
        if new:
            app.set_mode("pin")
    pins = {p.name: p for p in app.snap.data.pins}
    p = pins.get(app.selection[0]) if len(app.selection) == 1 else None
    if p is not None and p.kind == "starch":
        changed, r = imgui.slider_float(f"{p.name} radius", p.radius or STARCH_RADIUS, 4.0, 400.0, "%.0f px",
                                        imgui.SliderFlags_.logarithmic)
        imgui.set_item_tooltip("how far the starch pin stiffens the layer around it")
        note("slider:starch radius")
        live(app, "starch", f"radius of {p.name}")
        if changed:
            name = p.name
            app.edit(lambda s, r=float(r): s.set_pin_radius(name, r), key="starch-live")


def links(app) -> None:
    """The scene's links (select one) and the selected link's strength."""
    st, data = deformtools.state(app), app.snap.data
    if not data.links:
        imgui.text_disabled("no links (hinge or patch two layers, or draw a segment)")
        return
    for link in data.links:
        a, b = link.layers
        text = f"{a} + {b}: {len(link.segments)} seg, {len(link.points)} hinge, {len(link.polygons)} patch"
        clicked, _ = imgui.selectable(f"{text}##link-{a}-{b}", st.link is not None and set(st.link) == {a, b})
        note(f"link:{a}+{b}")
        if clicked:
            st.link = (a, b)
    link = next((x for x in data.links if st.link is not None and set(x.layers) == set(st.link)), None)
    if link is None:
        imgui.text_disabled("select a link for its strength")
        return
    a, b = link.layers
    changed, v = imgui.slider_float("strength##link", link.strength, 0.0, 1.0, "%.2f")
    imgui.set_item_tooltip("coupling across the link: 1 holds the layers together, 0 lets them part")
    note("slider:link strength")
    live(app, "strength", f"strength of {a}+{b}")
    if changed:
        app.edit(lambda s, v=float(v): s.set_link_strength(a, b, v), key="strength-live")
