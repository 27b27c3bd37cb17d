"""What is drawn over the canvas with ImGui's draw list: pins (interior, exterior and
automatic exterior points in their own colours, selected ones ringed, names on hover),
link segments, the link pencil's segment while it is drawn, the rig "Rig automatically"
proposes, and the depth legend."""
from __future__ import annotations

import math

import numpy as np
from imgui_bundle import imgui

from puppet.app.model import pick
from puppet.app.tools import autorig
from puppet.app.tools import deform as deformtools
from puppet.app.tools import link as linkpencil

#: pin colours (RGBA 0..1): interior, exterior pins, automatic exterior points, starch pins
COLOURS = {"interior": (1.0, 0.85, 0.1, 1.0), "exterior": (0.2, 0.75, 1.0, 1.0), "auto": (0.55, 0.85, 1.0, 0.9),
           "starch": (0.92, 0.92, 0.92, 1.0)}
SELECTED = (1.0, 0.25, 0.2, 1.0)
LINK = (0.1, 0.9, 0.35, 1.0)


def col(rgba) -> int:
    return imgui.color_convert_float4_to_u32(imgui.ImVec4(*rgba))


def draw_pins(dl, app, hovered: pick.Marker | None) -> None:
    """Pins as filled dots with a dark outline and a light ring round it (they show on any
    colour); selected pins ringed in red; the hovered
    pin's name next to it; the turning pin's angle as a tick."""
    view = app.view
    dark = col((0.0, 0.0, 0.0, 0.85))
    light = col((1.0, 1.0, 1.0, 0.85))
    s = app.marker_scale()  # smaller where the view crowds them (a big character in a small window)
    w = max(1.0, 1.5 * s)  # outline width
    cages = deformtools.cages_drawn(app)
    for m in app.markers():
        if cages and m.kind == "auto" and deformtools.cage_handle_of(app, m.name) is not None:
            continue  # drawn as a square of its cage (puppet.app.ui.deform_overlay)
        x, y = view.to_screen(app.marker_xy(m))
        c = col(COLOURS[m.kind])
        r = (4.0 if m.kind == "auto" else 5.5) * s
        if m.kind == "auto":
            dl.add_circle(imgui.ImVec2(x, y), r + s, dark, 0, 2 * w)
            dl.add_circle(imgui.ImVec2(x, y), r, c, 0, 4 * w / 3)
        elif m.kind == "starch":  # a square: it stiffens, it holds no position
            dl.add_rect_filled(imgui.ImVec2(x - r, y - r), imgui.ImVec2(x + r, y + r), c)
            dl.add_rect(imgui.ImVec2(x - r, y - r), imgui.ImVec2(x + r, y + r), dark, 0.0, w)
        elif m.kind == "exterior":  # a diamond
            pts = [imgui.ImVec2(x, y - r - s), imgui.ImVec2(x + r + s, y), imgui.ImVec2(x, y + r + s),
                   imgui.ImVec2(x - r - s, y)]
            dl.add_quad_filled(*pts, c)
            dl.add_quad(*pts, dark, w)
        else:
            dl.add_circle_filled(imgui.ImVec2(x, y), r, c)
            dl.add_circle(imgui.ImVec2(x, y), r, dark, 0, w)
        if m.kind != "auto":  # a light ring round the dark outline: the pin shows on any colour
            dl.add_circle(imgui.ImVec2(x, y), r + (3.0 if m.kind != "interior" else 2.0) * s, light, 0, w)
        if app.mode == "pose" and m.kind in ("interior", "exterior"):
            a = app.target_angle(m.name)
            if a:
                t, n = math.radians(a), 14 * s
                dl.add_line(imgui.ImVec2(x, y), imgui.ImVec2(x + n * math.cos(t), y - n * math.sin(t)), c, 2.0)
        if m.name in app.selection:
            dl.add_circle(imgui.ImVec2(x, y), r + 5.5 * s, col(SELECTED), 0, 2.0)
    if hovered is not None:
        x, y = view.to_screen(app.marker_xy(hovered))
        label = f"{hovered.name} ({hovered.kind})" if hovered.kind != "interior" else hovered.name
        layer = app.snap.data.layers[hovered.layer].name if app.snap.loaded else ""
        text = f"{label} on {layer}"
        size = imgui.calc_text_size(text)
        p0 = imgui.ImVec2(x + 10, y - size.y - 8)
        dl.add_rect_filled(p0, imgui.ImVec2(p0.x + size.x + 8, p0.y + size.y + 4), col((0.1, 0.1, 0.1, 0.85)), 3.0)
        dl.add_text(imgui.ImVec2(p0.x + 4, p0.y + 2), col((1, 1, 1, 1)), text)


def link_segments(app) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every link segment as drawn in the shown pose: its ends carried by the first
    layer's mesh (rest -> shown through the triangle that holds them)."""
    snap = app.snap
    out = []
    for link in snap.data.links:
        k = app.layer_index(link.layers[0])
        if k is None:
            continue
        r = snap.layers[k]
        for seg in link.segments:
            ends = [shown_point(r, p) for p in np.asarray(seg, float)]
            if all(e is not None for e in ends):
                out.append((ends[0], ends[1]))
    return out


shown_point = pick.shown_point  # where a layer result shows a rest point (None when off its mesh)


def draw_links(dl, app) -> None:
    c = col(LINK)
    for a, b in link_segments(app):
        pa, pb = app.view.to_screen(a), app.view.to_screen(b)
        dl.add_line(imgui.ImVec2(*pa), imgui.ImVec2(*pb), col((0, 0, 0, 0.8)), 5.0)
        dl.add_line(imgui.ImVec2(*pa), imgui.ImVec2(*pb), c, 3.0)


def draw_depth_legend(dl, app, lo: float, hi: float) -> None:
    x, y = app.area[0] + 10, app.area[1] + app.area[3] - 30
    w = 160
    stops = [(0.15, 0.25, 0.85), (0.1, 0.8, 0.85), (0.95, 0.85, 0.15), (0.9, 0.15, 0.1)]
    for i in range(3):
        a, b = col((*stops[i], 1)), col((*stops[i + 1], 1))
        dl.add_rect_filled_multi_color(imgui.ImVec2(x + i * w / 3, y), imgui.ImVec2(x + (i + 1) * w / 3, y + 10),
                                       a, b, b, a)
    white = col((1, 1, 1, 1))
    dl.add_text(imgui.ImVec2(x, y + 12), white, f"back {lo:g}")
    dl.add_text(imgui.ImVec2(x + w - 60, y + 12), white, f"front {hi:g}")


def draw_link_preview(dl, app) -> None:
    """The segment being drawn: the kept part solid (as a link), the dropped parts dashed;
    after the release the kept part stays until the scene shows the link, the dropped
    parts stay (faint) while the link holds the kept part, and a refused segment stays
    dashed with a red cross until the next gesture or a change of the scene."""
    p = app.script.link_preview
    if p is None:
        return
    col = imgui.get_color_u32
    view = app.view
    refused = p.kept is None
    pending = p.done and not refused and app.snap.done < p.job  # the edit is on its way
    if p.done and not refused and not pending and not linkpencil.stored(app, p):
        return  # undone, or the edit failed
    if p.done and refused and app.snap.data is not p.data:
        return  # the scene changed since (an undo, another edit): the refusal is old news
    drop = col(imgui.ImVec4(1.0, 1.0, 1.0, 0.5 if p.done and not refused else 0.8))
    dark = col(imgui.ImVec4(0.0, 0.0, 0.0, 0.6))
    for seg in p.dropped():
        s0, s1 = (np.asarray(view.to_screen(q), float) for q in seg)
        dashed(dl, s0, s1, dark, 4.0)
        dashed(dl, s0, s1, drop, 2.0)
    if refused and p.done:  # a red cross on the refused segment (dashes alone say "dropped")
        m = np.asarray(view.to_screen((p.p0 + p.p1) / 2), float)
        for w, c in ((6.0, dark), (3.0, col(imgui.ImVec4(1.0, 0.2, 0.15, 1.0)))):
            for d in (np.array([8.0, 8.0]), np.array([8.0, -8.0])):
                dl.add_line(imgui.ImVec2(*map(float, m - d)), imgui.ImVec2(*map(float, m + d)), c, w)
    if not refused and (not p.done or pending):  # once shown, the stored link draws the kept part
        k0, k1 = (imgui.ImVec2(*map(float, view.to_screen(q))) for q in p.kept)
        dl.add_line(k0, k1, col(imgui.ImVec4(0.0, 0.0, 0.0, 0.8)), 5.0)
        dl.add_line(k0, k1, col(imgui.ImVec4(*LINK)), 3.0)
        for k in (k0, k1):
            dl.add_circle_filled(k, 3.5, col(imgui.ImVec4(*LINK)))


def dashed(dl, s0, s1, color, thickness: float) -> None:
    """A dashed line from window point ``s0`` to ``s1`` (:data:`puppet.app.tools.link.DASH`)."""
    d = s1 - s0
    n = float(np.hypot(*d))
    if n < 0.5:
        return
    u = d / n
    t = 0.0
    while t < n:
        a, z = s0 + t * u, s0 + min(t + linkpencil.DASH[0], n) * u
        dl.add_line(imgui.ImVec2(float(a[0]), float(a[1])), imgui.ImVec2(float(z[0]), float(z[1])), color, thickness)
        t += linkpencil.DASH[0] + linkpencil.DASH[1]


#: the proposed rig's colour (it is not the scene's yet)
PROPOSED = (1.0, 0.45, 0.9, 1.0)


def draw_rig_proposal(dl, app) -> None:
    """The rig "Rig automatically" proposes, until accepted or discarded: glue segments as
    lines, hinges as rings, pins as dots, all magenta with a dark outline."""
    p = autorig.current(app)
    if p is None:
        return
    view, dark, c = app.view, col((0.0, 0.0, 0.0, 0.85)), col(PROPOSED)
    for k in p.links:
        for seg in k.get("segments", []):
            a, b = (imgui.ImVec2(*map(float, view.to_screen(q))) for q in seg)
            dl.add_line(a, b, dark, 5.0)
            dl.add_line(a, b, c, 3.0)
        for q in k.get("points", []):
            x, y = map(float, view.to_screen(q))
            dl.add_circle(imgui.ImVec2(x, y), 9.0, dark, 0, 4.0)
            dl.add_circle(imgui.ImVec2(x, y), 9.0, c, 0, 2.0)
    for pin in p.pins:
        x, y = map(float, view.to_screen(pin["at"]))
        dl.add_circle_filled(imgui.ImVec2(x, y), 6.0, dark)
        dl.add_circle_filled(imgui.ImVec2(x, y), 4.5, c)
