"""What the Deform panel's tools draw over the canvas with ImGui's draw list: the
stiffness heat map (the grey levels the solver sees, :func:`puppet.app.tools.deform.vertex_grey`),
hinges and patches, the patch being drawn, the brush stroke and cursor, the reach of
the selected starch pins, and the layers' cages (polygon and vertex squares).
"""
from __future__ import annotations

import ctypes

import numpy as np
from imgui_bundle import imgui

from puppet.app.model import pick
from puppet.app.tools import deform as deformtools
from puppet.scene.rig.stiffness import STARCH_RADIUS


def draw_overlay(dl, app) -> None:
    """The heat map (when View > Stiffness heat map is on), the patch draft, the brush."""
    st, view = deformtools.state(app), app.view
    col = imgui.get_color_u32
    if getattr(app, "show_stiffness", False) or st.tool == "stiffness":
        hidden = app.hidden_indices()
        order = sorted(range(len(app.snap.layers)), key=lambda k: app.snap.rank[k])
        for k in order:
            g = deformtools.vertex_grey(app, k) if k not in hidden else None
            if g is None:
                continue
            draw_heat(dl, view.to_screen(app.snap.layers[k].deformed), np.asarray(app.snap.layers[k].triangles), g)
    yellow = col(imgui.ImVec4(1.0, 0.9, 0.2, 1.0))
    if app.show_links or st.tool in ("hinge", "patch"):
        draw_hinges(dl, app)
    draw_starch_reach(dl, app)
    if deformtools.cages_drawn(app):
        draw_cages(dl, app)
    if st.tool == "chain":
        draw_chains(dl, app)
    if st.draft_screen:
        pts = [imgui.ImVec2(*map(float, view.to_screen(p))) for p in st.draft_screen]
        for p, q in zip(pts, pts[1:]):
            dl.add_line(p, q, yellow, 2.0)
        dl.add_circle(pts[0], deformtools.CLOSE_RADIUS, yellow, 0, 1.5)
    if st.stroke:
        pts = [imgui.ImVec2(*map(float, view.to_screen(p))) for p in st.stroke]
        for p, q in zip(pts, pts[1:]):
            dl.add_line(p, q, col(imgui.ImVec4(1.0, 0.2, 0.1, 0.8)), max(st.brush * view.scale, 1.0))
    if st.tool == "stiffness" and imgui.is_window_hovered():
        m = imgui.get_io().mouse_pos
        dl.add_circle(imgui.ImVec2(m.x, m.y), max(st.brush / 2 * view.scale, 2.0),
                      col(imgui.ImVec4(1.0, 1.0, 1.0, 0.8)), 0, 1.5)


def heat_colours(g: np.ndarray) -> np.ndarray:
    """Packed ImGui colours (n,) uint32 of grey levels g (n,) 0..255: transparent at 0,
    red more opaque as it stiffens."""
    alpha = np.where(g > 0.5, 0.2 + 0.6 * np.clip(g, 0, 255) / 255.0, 0.0)
    a = np.rint(alpha * 255).astype(np.uint32)
    return (a << 24) | (np.uint32(13) << 16) | (np.uint32(26) << 8) | np.uint32(255)  # ABGR: (255, 26, 13)


#: ImGui's vertex layout (imgui.VERTEX_SIZE bytes): position, texture uv, packed colour
_VERT = np.dtype([("pos", "<f4", 2), ("uv", "<f4", 2), ("col", "<u4")])


def draw_heat(dl, S: np.ndarray, F: np.ndarray, g: np.ndarray) -> None:
    """The heat map of one layer: its triangles F (m, 3) at window points S (n, 2),
    coloured per vertex from grey g (n,) (Gouraud-shaded by ImGui's vertex colours).

    The vertices and indices are written into the draw list's buffers in one copy each
    (reserved with ``prim_reserve``, as ImGui's own shapes do): a call per vertex costs
    tens of ms a frame for a few thousand triangles."""
    keep = np.flatnonzero(g[F].max(1) > 0.5)
    if not len(keep):
        return
    nv, ni = len(S), 3 * len(keep)  # every vertex (cheaper than picking the used ones)
    assert imgui.VERTEX_SIZE == _VERT.itemsize and imgui.INDEX_SIZE == 4
    vtx = np.empty(nv, _VERT)
    vtx["pos"] = S
    uv = imgui.get_font_tex_uv_white_pixel()
    vtx["uv"] = (uv.x, uv.y)
    vtx["col"] = heat_colours(g)
    dl.prim_reserve(ni, nv)
    base = dl._vtx_current_idx
    idx = (base + F[keep].reshape(-1)).astype(np.uint32)
    vb, ib = dl.vtx_buffer, dl.idx_buffer
    ctypes.memmove(vb.data_address() + (vb.size() - nv) * _VERT.itemsize, vtx.ctypes.data, vtx.nbytes)
    ctypes.memmove(ib.data_address() + (ib.size() - ni) * 4, idx.ctypes.data, idx.nbytes)
    dl._vtx_current_idx = base + nv
    # the copies did not move the write pointers that ImGui's own writes advance, and
    # imgui.render asserts that they stand at the buffers' ends (a crash whenever nothing
    # else was drawn into this list after the heat map, e.g. with pins and links hidden):
    # an empty reservation puts them there
    dl.prim_reserve(0, 0)


def draw_hinges(dl, app) -> None:
    """Link points as rings and link polygons as outlines (rest canvas, drawn where the
    first layer's mesh shows them)."""
    green = imgui.get_color_u32(imgui.ImVec4(0.1, 0.9, 0.35, 1.0))
    dark = imgui.get_color_u32(imgui.ImVec4(0.0, 0.0, 0.0, 0.85))
    snap, view = app.snap, app.view
    for link in snap.data.links:
        k = app.layer_index(link.layers[0])
        if k is None:
            continue
        r = snap.layers[k]

        def at(q, r=r):
            s = pick.shown_point(r, q)
            return imgui.ImVec2(*map(float, view.to_screen(q if s is None else s)))
        for P in link.polygons:
            dl.add_polyline([at(q) for q in P], green, 2.0, imgui.ImDrawFlags_.closed)
        for q in link.points:
            c = at(q)
            dl.add_circle(c, 7.0, dark, 0, 4.0)
            dl.add_circle(c, 7.0, green, 0, 2.0)


def draw_starch_reach(dl, app) -> None:
    """A faint circle of each selected starch pin's reach."""
    pins = {p.name: p for p in app.snap.data.pins if p.kind == "starch"}
    white = imgui.get_color_u32(imgui.ImVec4(1.0, 1.0, 1.0, 0.7))
    for name in app.selection:
        p, m = pins.get(name), app.marker(name)
        if p is not None and m is not None:
            c = app.view.to_screen(app.marker_xy(m))
            dl.add_circle(imgui.ImVec2(float(c[0]), float(c[1])), (p.radius or STARCH_RADIUS) * app.view.scale,
                          white, 0, 1.0)


#: the chains' colour (RGBA 0..1): cyan; the selected chain and the draft are drawn thicker
CHAIN = (0.2, 0.85, 1.0, 1.0)


def draw_chains(dl, app) -> None:
    """The physics chains through their pins as shown (the selected one thicker, each
    anchor ringed), and the chain tool's draft."""
    col = imgui.get_color_u32
    c, dark = col(imgui.ImVec4(*CHAIN)), col(imgui.ImVec4(0.0, 0.0, 0.0, 0.85))
    st = deformtools.state(app)
    at = {m.name: app.marker_xy(m) for m in app.markers()}
    lines = [(list(ch.pins), i == st.chain) for i, ch in enumerate(app.snap.data.chains)]
    if st.chain_draft:
        lines.append((list(st.chain_draft), True))
    for names, bold in lines:
        pts = [imgui.ImVec2(*map(float, app.view.to_screen(np.asarray(at[n], float)))) for n in names if n in at]
        if len(pts) >= 2:
            dl.add_polyline(pts, dark, 5.0 if bold else 4.0, 0)
            dl.add_polyline(pts, c, 3.0 if bold else 1.5, 0)
        if pts:
            dl.add_circle(pts[0], 9.0, c, 0, 2.0)  # the anchor


#: the cages' colour (RGBA 0..1): orange, apart from the pins, links and the proposed rig
CAGE = (1.0, 0.5, 0.05, 1.0)


def draw_cages(dl, app) -> None:
    """Each visible caged layer's cage as shown (a vertex drag's preview instead of its
    layer's): the polygon with a dark outline, its vertices as small squares, a selected
    vertex filled red."""
    col = imgui.get_color_u32
    c, dark = col(imgui.ImVec4(*CAGE)), col(imgui.ImVec4(0.0, 0.0, 0.0, 0.85))
    red = col(imgui.ImVec4(1.0, 0.2, 0.15, 1.0))
    preview = deformtools.cage_preview(app)
    for layer, C in deformtools.cages(app):
        if preview is not None and preview[0] == layer:
            C = preview[1]
        S = [imgui.ImVec2(*map(float, p)) for p in app.view.to_screen(C)]
        dl.add_polyline(S, dark, 4.0, imgui.ImDrawFlags_.closed)
        dl.add_polyline(S, c, 2.0, imgui.ImDrawFlags_.closed)
        for j, p in enumerate(S):
            a, b = imgui.ImVec2(p.x - 4.0, p.y - 4.0), imgui.ImVec2(p.x + 4.0, p.y + 4.0)
            dl.add_rect_filled(a, b, red if deformtools.handle(layer, j) in app.selection else c)
            dl.add_rect(a, b, dark, 0.0, 1.0)
