"""The canvas, drawn with GL on the window's context: a checkerboard behind transparency,
the scene background, the reference underlay, the composited layers, and the mesh views
(wireframe, colour by interpolated depth); its GLSL programs are ``shaders/app_quad.glsl``
and ``shaders/app_mesh.glsl``.

The layers are composited by puppet's :class:`~puppet.render.compositor.Compositor`
(the same per-pixel depth compositing as ``puppet render``, through its window path
``draw``: into a texture, no read-back) at window resolution over the visible part of
the canvas (and of the layers posed past its edge, drawn dimmed on the pasteboard), and
composited again only when the shown layers or the view change; every other frame
redraws the cached texture.
"""
from __future__ import annotations

import time

import moderngl
import numpy as np
from pyglet import gl

from puppet.render.compositor import Compositor
from puppet.render.layers import DrawLayer, mesh_edges
from puppet.render.programs import load_program

#: most pixels a drag preview is composited at (about 500x500); the exact frame is full size
PREVIEW_PIXELS = 250_000
#: opacity of the layers' parts past the canvas edge, drawn on the pasteboard (as Spine)
PASTEBOARD_DIM = 0.4
#: the composited rect is grown to multiples of this (window px) when parts show past the edge
RECT_STEP = 64
#: the pasteboard round the canvas (RGB 0..1)
PASTEBOARD = (0.16, 0.16, 0.17)


def depth_range(layers) -> tuple[float, float]:
    """Lowest and highest drawn depth over ``layers`` (LayerResults)."""
    ds = [np.asarray(r.depth) for r in layers if len(r.depth)]
    if not ds:
        return (0.0, 1.0)
    return (float(min(d.min() for d in ds)), float(max(d.max() for d in ds)))


class CanvasRenderer:
    """GL drawing of the canvas area (main thread only).

    Attributes
    ----------
    composite_ms : float
        Time of the last composite (0 when the cached texture was reused).
    composites : int
        How many composites have been made (tests check the cache with it).
    stale_errors : list of str
        GL errors found pending just before a composite: left by the canvas's own calls
        (the compositor would otherwise report them as its own).
    """

    def __init__(self, ctx: moderngl.Context, compositor=None):
        self.ctx = ctx
        self.compositor = compositor or Compositor(ctx)
        self.tex_prog = load_program(ctx, "app_quad")
        self.checker_prog = load_program(ctx, "app_quad", defines={"CHECKER": 1})
        self.paste_prog = load_program(ctx, "app_quad", defines={"PASTEBOARD": 1})
        self.depth_prog = load_program(ctx, "app_mesh", defines={"DEPTH": 1})
        self.wire_prog = load_program(ctx, "app_mesh", defines={"WIRE": 1})
        self.quad_vbo = ctx.buffer(reserve=4 * 4 * 4)
        self.quads = {self.tex_prog: ctx.vertex_array(self.tex_prog, [(self.quad_vbo, "2f 2f", "in_pos", "in_uv")]),
                      self.checker_prog: ctx.vertex_array(self.checker_prog, [(self.quad_vbo, "2f 8x", "in_pos")]),
                      self.paste_prog: ctx.vertex_array(self.paste_prog, [(self.quad_vbo, "2f 2f", "in_pos", "in_uv")])}
        self.mesh_vbo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.mesh_ibo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.solid = ctx.texture((1, 1), 4)
        self.textures: dict[str, tuple[object, moderngl.Texture]] = {}
        self.frame_tex: moderngl.Texture | None = None
        self._frame_key = None
        self._frame_rect = None
        self._bounds: tuple = (None, None)  # (key, (lo, hi)) of the shown layers' posed vertices
        self._names: tuple[str, ...] = ()  # the layer names the compositor's caches were last trimmed to
        self.composite_ms = 0.0
        self.composites = 0
        self.preview_pixels = PREVIEW_PIXELS
        self.fast = False  # composite every snapshot like a drag preview (while playing)
        self.last_scale = 1.0
        self._depth_fbo = self._depth_rb = self._depth_tex = None
        self._edges: dict[int, tuple] = {}
        self.stale_errors: list[str] = []  # GL errors found pending before a composite (kept for tests)

    # -- helpers ------------------------------------------------------------------
    def _quad(self, prog, screen, rect, uv=(0, 0, 1, 1)) -> None:
        x0, y0, x1, y1 = rect
        u0, v0, u1, v1 = uv
        self.quad_vbo.write(np.array([x0, y0, u0, v0, x1, y0, u1, v0, x0, y1, u0, v1, x1, y1, u1, v1],
                                     np.float32))
        prog["u_screen"].value = screen
        self.quads[prog].render(moderngl.TRIANGLE_STRIP)

    def _texture(self, key: str, image: np.ndarray) -> moderngl.Texture:
        entry = self.textures.get(key)
        if entry is not None and entry[0] is image:
            return entry[1]
        if entry is not None:
            entry[1].release()
        h, w = image.shape[:2]
        tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(image).tobytes())
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        self.textures[key] = (image, tex)
        return tex

    def _image(self, screen, view, image, offset, size, alpha: float, key: str) -> None:
        """Draw ``image`` over canvas rect at ``offset`` with ``size`` (canvas units)."""
        tex = self._texture(key, image)
        tex.use(0)
        self.tex_prog["u_texture"].value = 0
        self.tex_prog["u_alpha"].value = float(alpha)
        p0 = view.to_screen(offset)
        p1 = view.to_screen((offset[0] + size[0], offset[1] + size[1]))
        self._quad(self.tex_prog, screen, (p0[0], p0[1], p1[0], p1[1]))

    # -- the frame ----------------------------------------------------------------
    def draw(self, snap, view, area, screen, *, hidden=frozenset(), depth_view=False, wireframe=False,
             fb_height: int | None = None, tint=None, under=None) -> None:
        """Draw the canvas of snapshot ``snap`` into window rect ``area`` (x, y, w, h);
        ``tint``: (key, rgba (H, W, 4) straight alpha, canvas offset) drawn over the layers;
        ``under(screen, view, rect)``: drawn behind the layers (the onion skin's ghosts)."""
        ctx = self.ctx
        fb_h = int(fb_height or screen[1])
        ax, ay, aw, ah = area
        ctx.viewport = (0, 0, int(screen[0]), int(screen[1]))
        ctx.scissor = (int(ax), int(fb_h - ay - ah), int(aw), int(ah))
        ctx.clear(*PASTEBOARD, 1.0)
        self.composite_ms = 0.0
        if not snap.loaded:
            ctx.scissor = None
            return
        vis = view.visible(snap.canvas, area)
        shown = [(r, im) for r, im in zip(snap.layers, snap.images) if r.name not in hidden]
        rect = vis[0] if vis is not None else None
        bounds = self._posed_bounds(shown, (snap.version, snap.file, tuple(r.name for r, _ in shown)))
        full = self._content_rect(bounds, view, area, rect)  # the canvas and what sticks out of it
        if full is None:
            ctx.scissor = None
            return
        bg = snap.background
        u = snap.underlay if snap.underlay_image is not None else None
        opaque = not isinstance(bg, np.ndarray) and bg[3] == 255 and u is None and not depth_view and under is None
        if opaque and full == rect:
            # the common case: one opaque composite over the scene's colour, as `puppet render`
            tex = self._composite(shown, view, rect, snap, background=tuple(bg))
            ctx.enable_only(moderngl.NOTHING)
            self._frame_quad(tex, screen, rect)
        elif opaque:  # and parts past the edge: one pass puts the colour and the pasteboard under them
            tex = self._composite(shown, view, full, snap)
            ctx.enable_only(moderngl.NOTHING)
            self._pasteboard_quad(tex, screen, full, rect, fb_h, (*(c / 255.0 for c in bg[:3]), 1.0))
        else:
            ctx.enable_only(moderngl.BLEND)
            ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA, moderngl.ONE,
                              moderngl.ONE_MINUS_SRC_ALPHA)
            if rect is not None:
                self._canvas_under(snap, view, screen, rect, under)
            if depth_view and rect is not None:
                self._draw_depth(shown, view, screen, rect)
                ctx.scissor = (int(ax), int(fb_h - ay - ah), int(aw), int(ah))
            elif not depth_view:
                tex = self._composite(shown, view, full, snap)
                ctx.enable_only(moderngl.BLEND)
                ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)  # premultiplied
                if full == rect:
                    self._frame_quad(tex, screen, rect)
                else:  # content past the canvas edge shows dimmed on the pasteboard
                    self._pasteboard_quad(tex, screen, full, rect, fb_h)
        if tint is not None:
            ctx.enable_only(moderngl.BLEND)
            ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA, moderngl.ONE,
                              moderngl.ONE_MINUS_SRC_ALPHA)
            key, rgba, offset = tint
            self._image(screen, view, rgba, offset, (rgba.shape[1], rgba.shape[0]), 1.0, key)
        if wireframe:
            self._draw_wire(shown, view, screen)
        ctx.enable_only(moderngl.NOTHING)
        ctx.scissor = None

    def _frame_quad(self, tex, screen, rect) -> None:
        tex.use(0)
        self.tex_prog["u_texture"].value = 0
        self.tex_prog["u_alpha"].value = 1.0
        self._quad(self.tex_prog, screen, rect)

    def _pasteboard_quad(self, tex, screen, rect, canvas, fb_h: int, under=None) -> None:
        """The composited ``rect``, its part outside window rect ``canvas`` (or all of it,
        when the canvas is out of view) at :data:`PASTEBOARD_DIM`. ``under``: the canvas's
        opaque colour (RGBA 0..1), put under the layers inside the canvas and the
        pasteboard's outside, in the same pass (opaque output, no blending); None: the
        output is premultiplied, to blend over what is drawn."""
        prog = self.paste_prog
        tex.use(0)
        prog["u_texture"].value = 0
        prog["u_dim"].value = PASTEBOARD_DIM
        cx0, cy0, cx1, cy1 = canvas if canvas is not None else (0, 0, 0, 0)
        prog["u_canvas"].value = (float(cx0), float(fb_h - cy1), float(cx1), float(fb_h - cy0))  # GL's y is up
        prog["u_inside"].value = tuple(under) if under is not None else (0.0, 0.0, 0.0, 0.0)
        prog["u_outside"].value = (*PASTEBOARD, 1.0) if under is not None else (0.0, 0.0, 0.0, 0.0)
        self._quad(prog, screen, rect)

    def _canvas_under(self, snap, view, screen, rect, under) -> None:
        """What lies under the layers on the canvas's own rect: the checkerboard behind a
        transparent background, the background picture or colour, the reference underlay,
        the onion skin's ghosts."""
        bg = snap.background
        if isinstance(bg, np.ndarray) or bg[3] < 255:
            self.checker_prog["u_cell"].value = 8.0
            self._quad(self.checker_prog, screen, rect)
        if isinstance(bg, np.ndarray):
            self._image(screen, view, bg, (0, 0), snap.canvas, 1.0, "\0background")
        elif bg[3] > 0:
            self.solid.write(np.asarray(bg, np.uint8).tobytes())
            self.solid.use(0)
            self.tex_prog["u_texture"].value = 0
            self.tex_prog["u_alpha"].value = 1.0
            self._quad(self.tex_prog, screen, rect)
        if snap.underlay_image is not None:
            u = snap.underlay
            h, w = snap.underlay_image.shape[:2]
            sc = float(u.get("scale", 1.0))
            self._image(screen, view, snap.underlay_image, u.get("offset", (0, 0)), (w * sc, h * sc),
                        float(u.get("opacity", 0.5)), "\0underlay")
        if under is not None:
            under(screen, view, rect)

    def _posed_bounds(self, shown, key):
        """(lo, hi) canvas corners of the shown layers' posed vertices (None: no vertex),
        kept until ``key`` (the snapshot and the shown layers) changes: the reductions over
        every vertex cost ~13 ms a frame on the 45k vertices of a 4K PSD."""
        if self._bounds[0] != key:
            pts = [np.asarray(r.deformed).reshape(-1, 2) for r, _ in shown if len(r.deformed)]
            box = None
            if pts:
                box = (np.min([(p[:, 0].min(), p[:, 1].min()) for p in pts], axis=0),
                       np.max([(p[:, 0].max(), p[:, 1].max()) for p in pts], axis=0))
            self._bounds = (key, box)
        return self._bounds[1]

    def _content_rect(self, bounds, view, area, rect):
        """Window rect (ints) of the visible canvas ``rect`` grown to the layers' posed
        ``bounds`` (see :meth:`_posed_bounds`), both cut to ``area``; None when neither shows."""
        out = rect
        if bounds is not None:
            lo, hi = bounds
            (x0, y0), (x1, y1) = view.to_screen(lo), view.to_screen(hi)
            ax, ay, aw, ah = area
            b = (max(int(np.floor(x0)), int(np.floor(ax))), max(int(np.floor(y0)), int(np.floor(ay))),
                 min(int(np.ceil(x1)), int(np.ceil(ax + aw))), min(int(np.ceil(y1)), int(np.ceil(ay + ah))))
            if b[2] > b[0] and b[3] > b[1]:
                out = b if out is None else (min(out[0], b[0]), min(out[1], b[1]), max(out[2], b[2]), max(out[3], b[3]))
        if out is not None and out != rect:
            # grown to whole steps of RECT_STEP px, so that the composite's texture and
            # targets keep their size while a drag moves parts past the edge (allocating
            # them again every frame cost more than the pixels)
            x0, y0, x1, y1 = out
            out = (x0, y0, x0 + -(-(x1 - x0) // RECT_STEP) * RECT_STEP, y0 + -(-(y1 - y0) // RECT_STEP) * RECT_STEP)
        return out

    def _composite(self, shown, view, rect, snap, background=(0, 0, 0, 0)) -> moderngl.Texture:
        """The visible layers composited at window resolution over ``background`` (cached
        until the layers or the view change). A drag preview larger than
        :attr:`preview_pixels` is composited smaller and stretched (linear filtering); the
        exact pose on release is composited at full resolution again."""
        x0, y0, x1, y1 = rect
        fast = snap.preview or self.fast
        key = (snap.version, snap.file, view.scale, view.origin, rect, tuple(r.name for r, _ in shown), background,
               fast)
        if key == self._frame_key and self.frame_tex is not None:
            return self.frame_tex
        t = time.perf_counter()
        w, h = x1 - x0, y1 - y0
        f = 1.0
        if fast and w * h > self.preview_pixels:
            f = float(np.sqrt(self.preview_pixels / (w * h)))
        size = (max(1, int(round(w * f))), max(1, int(round(h * f))))
        fx, fy = size[0] / w, size[1] / h
        origin = np.asarray(view.origin, float) - (x0, y0)
        draw = [DrawLayer(key=r.name, image=im.drawn[0], offset=im.drawn[1], rest=r.rest,
                          deformed=(np.asarray(r.deformed, float) * view.scale + origin) * (fx, fy),
                          triangles=r.triangles, depth=r.depth) for r, im in shown]
        if self.frame_tex is None or self.frame_tex.size != size:
            if self.frame_tex is not None:
                self.frame_tex.release()
            self.frame_tex = self.ctx.texture(size, 4)
        self.frame_tex.filter = (moderngl.NEAREST, moderngl.NEAREST) if f == 1.0 else (moderngl.LINEAR, moderngl.LINEAR)
        names = tuple(r.name for r in snap.layers)
        if names != self._names:  # a layer renamed or removed: its texture and buffers go
            self.compositor.retain(names)
            self._names = names
        stale = self.ctx.error  # an error flag of the canvas's own calls: not the compositor's
        if stale != "GL_NO_ERROR":
            self.stale_errors = (self.stale_errors + [stale])[-20:]  # the latest few, not one a frame forever
        # the compositor's window path: into the texture, no read-back, premultiplied RGBA
        self.compositor.draw(draw, size, target=self.frame_tex, background=background, preview=fast)
        # Wait for the GL's work here, through ctypes, which lets go of the GIL: moderngl keeps
        # it in every call, so the first call that needs this frame (the quad sampling it)
        # would otherwise hold the scene thread's solve while llvmpipe rasterizes
        gl.glFinish()
        self.ctx.error  # noqa: B018 - clear a flag the compositor left
        self.ctx.screen.use()
        self._frame_key = key
        self.composite_ms = (time.perf_counter() - t) * 1000
        self.composites += 1
        self.last_scale = f
        return self.frame_tex

    def _mesh_arrays(self, shown):
        """Joint vertex arrays of the shown layers: positions (n, 2), depths (n,), and each
        layer's first vertex index."""
        if not shown:
            return None
        pos = np.concatenate([np.asarray(r.deformed, np.float32) for r, _ in shown])
        dep = np.concatenate([np.asarray(r.depth, np.float32) for r, _ in shown])
        bases = np.cumsum([0] + [len(r.deformed) for r, _ in shown])[:-1]
        return pos, dep, bases

    def _upload(self, pos, dep, indices) -> moderngl.VertexArray:
        data = np.empty((len(pos), 3), np.float32)
        data[:, :2], data[:, 2] = pos, dep
        for buf, arr in ((self.mesh_vbo, data), (self.mesh_ibo, indices)):
            if buf.size < arr.nbytes:
                buf.orphan(arr.nbytes * 2)
            buf.write(np.ascontiguousarray(arr))
        return data

    def _set_view(self, prog, view, screen) -> None:
        prog["u_screen"].value = screen
        prog["u_scale"].value = float(view.scale)
        prog["u_origin"].value = tuple(map(float, view.origin))

    def _draw_depth(self, shown, view, screen, rect) -> None:
        """Colour by interpolated depth, nearest in front, drawn offscreen (own depth buffer)
        over the visible rect and put on the window."""
        arrays = self._mesh_arrays(shown)
        if arrays is None:
            return
        pos, dep, bases = arrays
        tri = np.concatenate([np.asarray(r.triangles) + b for (r, _), b in zip(shown, bases)]).astype(np.int32)
        self._upload(pos, dep, tri)
        x0, y0, x1, y1 = rect
        size = (x1 - x0, y1 - y0)
        if self._depth_fbo is None or self._depth_fbo.size != size:
            self._release_depth_target()
            self._depth_tex = self.ctx.texture(size, 4)
            self._depth_rb = self.ctx.depth_renderbuffer(size)
            self._depth_fbo = self.ctx.framebuffer([self._depth_tex], self._depth_rb)
        ctx = self.ctx
        ctx.scissor = None
        self._depth_fbo.use()
        self._depth_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        prog = self.depth_prog
        prog["u_screen"].value = tuple(map(float, size))
        prog["u_scale"].value = float(view.scale)
        prog["u_origin"].value = (float(view.origin[0] - x0), float(view.origin[1] - y0))
        prog["u_range"].value = depth_range([r for r, _ in shown])
        vao = ctx.vertex_array(prog, [(self.mesh_vbo, "2f 1f", "in_pos", "in_depth")],
                               index_buffer=self.mesh_ibo, index_element_size=4)
        vao.render(moderngl.TRIANGLES, vertices=tri.size)
        vao.release()
        ctx.screen.use()
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
        self._depth_tex.use(0)
        self.tex_prog["u_texture"].value = 0
        self.tex_prog["u_alpha"].value = 0.9
        self._quad(self.tex_prog, screen, rect, uv=(0, 1, 1, 0))

    def _release_depth_target(self) -> None:
        for obj in (self._depth_fbo, self._depth_rb, self._depth_tex):
            if obj is not None:
                obj.release()
        self._depth_fbo = self._depth_rb = self._depth_tex = None

    def _draw_wire(self, shown, view, screen) -> None:
        arrays = self._mesh_arrays(shown)
        if arrays is None:
            return
        pos, dep, bases = arrays
        edges = np.concatenate([self._edges_of(r) + b for (r, _), b in zip(shown, bases)]).astype(np.int32)
        self._upload(pos, dep, edges)
        ctx = self.ctx
        ctx.enable_only(moderngl.BLEND)
        self._set_view(self.wire_prog, view, screen)
        self.wire_prog["u_color"].value = (0.1, 0.1, 0.12, 0.75)
        vao = ctx.vertex_array(self.wire_prog, [(self.mesh_vbo, "2f 4x", "in_pos")],
                               index_buffer=self.mesh_ibo, index_element_size=4)
        vao.render(moderngl.LINES, vertices=edges.size)
        vao.release()

    def _edges_of(self, r) -> np.ndarray:
        """Unique edges (k, 2) of one layer's triangles, cached per triangle array."""
        e = self._edges.get(id(r.triangles))
        if e is None or e[0] is not r.triangles:
            e = self._edges[id(r.triangles)] = (r.triangles, mesh_edges(r.triangles))
        return e[1]

    def release(self) -> None:
        for _, tex in self.textures.values():
            tex.release()
        self.textures.clear()
        if self.frame_tex is not None:
            self.frame_tex.release()
        self._release_depth_target()
        self.compositor.release()
