"""Per-pixel depth compositing of textured layer meshes (front-to-back depth peeling).

Each layer is a textured triangle mesh with a per-vertex depth (higher = in front),
interpolated across each triangle: which layer is in front is decided per pixel, so a
limb can pass behind the body and in front again, and a layer can overlap itself.
Edge pixels are semi-transparent, so a depth test with blending would leave halos.
Instead, front-to-back depth peeling (Everitt 2001) into a premultiplied accumulation
``A`` (half-float, two textures used in turn):

1. peel *k* draws every layer (nearest first) with depth test LESS into an RGBA8 colour
   and a depth target; the shader discards fragments whose texture alpha is below
   :data:`ALPHA_MIN` and, from the second peel on, those not behind peel *k-1*'s depth,
   so each pixel gets its *k*-th nearest fragment;
2. one full-screen pass puts the peel under the accumulation,
   ``A' = A + (1 - A.a) * peel``, and writes the next peel's depth buffer: 0 where
   ``A'`` is opaque (>= :data:`OPAQUE`), so nothing is drawn there again, 1 elsewhere.

Peeling stops when an occlusion query counts no sample in a peel, or after
``max_peels`` peels (fragments beyond are dropped). The optional wireframe goes over
``A``; a last pass puts the background under it and writes straight-alpha RGBA8.

Depths map to window depth normalised over the frame's min/max with a margin. Exact
ties between layers go to the later one in the list (a bias of a few depth-buffer
steps per list position); within one layer they are arbitrary.
"""
from __future__ import annotations

import contextlib

import moderngl
import numpy as np

from .context import create_context
from .layers import (EPSILON, DrawLayer, _check_background, _check_layer, mesh_edges,  # noqa: F401
                     premultiply, window_depths)
from .programs import load_program, set_uniform

#: Fragments whose premultiplied texture alpha is below this are discarded (peel.glsl).
ALPHA_MIN = 0.5 / 255.0
#: Accumulated alpha from which a pixel is final and later peels skip it.
OPAQUE = 1.0 - 1.0 / 1024.0
#: Wireframe colour, straight RGBA in 0..1.
WIRE_COLOR = (0.08, 0.08, 0.08, 0.7)

_OWN = object()  # tag in the .extra of the compositor's own framebuffers
#: Texture formats of the accumulation and of one peel (moderngl dtypes).
ACCUM_DTYPE = "f2"
PEEL_DTYPE = "f1"


class _Targets:
    """Render targets of one output size."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int]):
        self.size = size
        self.accums = [ctx.texture(size, 4, dtype=ACCUM_DTYPE) for _ in range(2)]
        self.peel = ctx.texture(size, 4, dtype=PEEL_DTYPE)
        self.depths = [ctx.depth_texture(size) for _ in range(2)]
        for tex in self.depths:
            tex.compare_func = ""  # sample raw depth, not a comparison (texelFetch only)
        self.peel_fbos = [ctx.framebuffer([self.peel], d) for d in self.depths]
        self.peel_color_fbo = ctx.framebuffer([self.peel])  # to clear the colour only
        # under_fbos[i][j] writes accumulation i and the depth buffer j of the next peel
        self.under_fbos = [[ctx.framebuffer([a], d) for d in self.depths] for a in self.accums]
        self.out = ctx.renderbuffer(size, 4)
        self.out_fbo = ctx.framebuffer([self.out])
        for fbo in self._fbos():
            fbo.extra = _OWN  # never rebound as "the caller's" framebuffer

    def _fbos(self):
        return (*self.peel_fbos, self.peel_color_fbo, *self.under_fbos[0],
                *self.under_fbos[1], self.out_fbo)

    def release(self) -> None:
        for obj in (*self._fbos(), *self.accums, self.peel, *self.depths, self.out):
            obj.release()


class _Mesh:
    """GPU buffers of one layer key: vertices rewritten each frame, indices kept."""

    def __init__(self, ctx: moderngl.Context, tri: np.ndarray, nbytes: int, peel_programs):
        self.triangles = tri.copy()
        self.vbo = ctx.buffer(reserve=nbytes)
        self.ibo = ctx.buffer(np.ascontiguousarray(tri, np.int32))
        self.vaos = {p: ctx.vertex_array(p, [(self.vbo, "2f 2f 1f", "in_pos", "in_uv", "in_z")],
                                         index_buffer=self.ibo, index_element_size=4)
                     for p in peel_programs}
        self.edge_ibo = self.edge_vao = None  # made on the first wireframe

    def fits(self, tri: np.ndarray, nbytes: int) -> bool:
        return self.vbo.size == nbytes and np.array_equal(self.triangles, tri)

    def edges(self, ctx: moderngl.Context, wire_program) -> moderngl.VertexArray:
        if self.edge_vao is None:
            self.edge_ibo = ctx.buffer(mesh_edges(self.triangles))
            self.edge_vao = ctx.vertex_array(wire_program, [(self.vbo, "2f 12x", "in_pos")],
                                             index_buffer=self.edge_ibo, index_element_size=4)
        return self.edge_vao

    def release(self) -> None:
        for obj in (*self.vaos.values(), self.edge_vao, self.vbo, self.ibo, self.edge_ibo):
            if obj is not None:
                obj.release()


class Compositor:
    """Composite :class:`DrawLayer` meshes by per-pixel depth into RGBA images.

    Parameters
    ----------
    ctx : moderngl.Context, optional
        Context to draw with (current on this thread). When None, an EGL standalone
        context is created, owned and released by the compositor.
    max_peels : int, optional
        Most depth peels per frame (default 6): the number of fragments, nearest
        first, that can show through one another at a pixel.

    Attributes
    ----------
    last_peels : int
        Peels that drew something in the last :meth:`render` (early stop by occlusion
        query); equal to ``max_peels`` when fragments may have been dropped.

    Notes
    -----
    Use it from the context's thread only. An owned context is made current around each
    call (several compositors can share a thread); a context passed in must be current.
    ``render`` changes GL state (enable flags, blend and depth functions, line width,
    texture units 0-3) and rebinds the caller's framebuffer, if one was bound.
    """

    def __init__(self, ctx: moderngl.Context | None = None, *, max_peels: int = 6):
        if max_peels < 1:
            raise ValueError(f"max_peels must be at least 1, got {max_peels}")
        self._own_ctx = ctx is None
        self.ctx = create_context() if ctx is None else ctx
        self.max_peels = int(max_peels)
        self.last_peels = 0
        with self._current():
            ctx = self.ctx
            self._peel_first = load_program(ctx, "peel", defines={"FIRST_PEEL": 1})
            self._peel_next = load_program(ctx, "peel")
            self._under_prog = load_program(ctx, "under")
            self._resolve_prog = load_program(ctx, "resolve")
            self._wire = load_program(ctx, "wire")
            self._fullscreen = {p: ctx.vertex_array(p, []) for p in
                                (self._under_prog, self._resolve_prog)}
            self._query = ctx.query(samples=True)
            self._bg_color = self._make_texture(np.zeros((1, 1, 4), np.uint8))
        self._textures: dict[str, tuple[np.ndarray, moderngl.Texture]] = {}
        self._meshes: dict[str, _Mesh] = {}
        self._targets: _Targets | None = None

    # -- public -------------------------------------------------------------------
    def render(self, layers: list[DrawLayer], canvas: tuple[int, int], *,
               size: tuple[int, int] | None = None,
               background: tuple[int, int, int, int] | np.ndarray = (0, 0, 0, 0),
               wireframe: bool = False) -> np.ndarray:
        """Composite ``layers`` over ``background``.

        Parameters
        ----------
        layers : list of DrawLayer
            Keys must be unique within the call; list order only breaks exact depth ties.
        canvas : (int, int)
            Canvas (width, height) in the pixels the layer coordinates use.
        size : (int, int), optional
            Output (width, height); the canvas is scaled to it. Default: ``canvas``.
        background : 4 ints 0..255 or ndarray (H, W, 4) uint8
            Straight RGBA colour, or an image stretched over the whole canvas.
        wireframe : bool
            Draw every layer's deformed mesh edges (1 px, dark, semi-opaque) on top.

        Returns
        -------
        ndarray, shape (H_out, W_out, 4), uint8
            Straight-alpha RGBA, row 0 = top.
        """
        cw, ch = (int(v) for v in canvas)
        size = (cw, ch) if size is None else (int(size[0]), int(size[1]))
        if min(cw, ch, *size) <= 0:
            raise ValueError(f"canvas {canvas} and size {size} must be positive")
        if len({layer.key for layer in layers}) != len(layers):
            raise ValueError("layer keys must be unique within one render call")
        for layer in layers:
            _check_layer(layer)
        background = _check_background(background)
        with self._current():
            return self._render(layers, (float(cw), float(ch)), size, background, wireframe)

    def invalidate(self, key: str | None = None) -> None:
        """Forget the cached texture and buffers of ``key`` (all keys when None)."""
        keys = list(self._textures.keys() | self._meshes.keys()) if key is None else [key]
        with self._current():
            for k in keys:
                entry = self._textures.pop(k, None)
                if entry is not None:
                    entry[1].release()
                mesh = self._meshes.pop(k, None)
                if mesh is not None:
                    mesh.release()

    def release(self) -> None:
        """Release every GL object (and the context when the compositor created it).

        The compositor cannot be used afterwards; a second call does nothing.
        """
        if self._bg_color is None:
            return
        self.invalidate()
        with self._current():
            if self._targets is not None:
                if self.ctx.fbo is not None and self.ctx.fbo.extra is _OWN:
                    self.ctx.detect_framebuffer(0).use()  # the default framebuffer
                self._targets.release()
                self._targets = None
            for vao in self._fullscreen.values():
                vao.release()
            self._fullscreen = {}
            self._bg_color.release()
            self._bg_color = None
        if self._own_ctx:
            self.ctx.release()

    # -- passes -------------------------------------------------------------------
    def _current(self):
        """Make an owned context current for a block (several may live in one thread)."""
        return self.ctx if self._own_ctx else contextlib.nullcontext()

    def _render(self, layers, canvas, size, background, wireframe) -> np.ndarray:
        ctx = self.ctx
        previous_fbo = ctx.fbo
        targets = self._targets_for(size)
        drawn = [layer for layer in layers if len(layer.triangles) and len(layer.deformed)]
        draws = [(self._texture(layer.key, layer.image), self._upload(layer, z), float(z.mean()))
                 for layer, z in zip(drawn, window_depths(drawn))]
        draws.sort(key=lambda d: d[2])  # nearest first: more early depth-test rejection
        for prog in (self._peel_first, self._peel_next, self._wire):
            set_uniform(prog, "u_canvas", canvas)
        self.last_peels, accum = self._peel([d[:2] for d in draws], targets)
        if wireframe:
            self._draw_wireframe([d[1] for d in draws], targets, accum)
        ctx.enable_only(moderngl.NOTHING)
        targets.out_fbo.use()
        targets.accums[accum].use(0)
        self._background(background).use(1)
        set_uniform(self._resolve_prog, "u_accum", 0)
        set_uniform(self._resolve_prog, "u_background", 1)
        self._fullscreen[self._resolve_prog].render(moderngl.TRIANGLES, vertices=3)
        out = np.empty((size[1], size[0], 4), np.uint8)
        targets.out_fbo.read_into(out, components=4)
        error = ctx.error
        if previous_fbo is not None and previous_fbo.extra is not _OWN:
            previous_fbo.use()
        if error != "GL_NO_ERROR":
            raise RuntimeError(f"OpenGL error while compositing: {error}")
        return out

    def _peel(self, draws, targets: _Targets) -> tuple[int, int]:
        """Peel front to back; return (peels that drew something, index of the result)."""
        ctx = self.ctx
        set_uniform(self._peel_first, "u_texture", 0)
        set_uniform(self._peel_next, "u_texture", 0)
        set_uniform(self._peel_next, "u_prev_depth", 1)
        set_uniform(self._peel_next, "u_epsilon", EPSILON)
        set_uniform(self._under_prog, "u_accum", 2)
        set_uniform(self._under_prog, "u_peel", 3)
        set_uniform(self._under_prog, "u_opaque", OPAQUE)
        targets.under_fbos[0][0].clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        src, peels = 0, 0
        for k in range(self.max_peels):
            cur = k % 2
            targets.peel_color_fbo.clear(0.0, 0.0, 0.0, 0.0)
            targets.peel_fbos[cur].use()
            ctx.enable_only(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
            targets.depths[1 - cur].use(1)
            program = self._peel_first if k == 0 else self._peel_next
            with self._query:
                for texture, mesh in draws:
                    texture.use(0)
                    mesh.vaos[program].render(moderngl.TRIANGLES)
            if self._query.samples == 0:
                break
            peels += 1
            # A' = A + (1 - A.a) * peel into the other accumulation, next depth mask
            targets.under_fbos[1 - src][1 - cur].use()
            ctx.depth_func = "1"
            targets.accums[src].use(2)
            targets.peel.use(3)
            self._fullscreen[self._under_prog].render(moderngl.TRIANGLES, vertices=3)
            src = 1 - src
        return peels, src

    def _draw_wireframe(self, meshes, targets: _Targets, accum: int) -> None:
        """Lines over the accumulation (so over the background too, as "over" is
        associative)."""
        ctx = self.ctx
        targets.under_fbos[accum][0].use()
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
        ctx.line_width = 1.0
        r, g, b, a = WIRE_COLOR
        set_uniform(self._wire, "u_color", (r * a, g * a, b * a, a))
        for mesh in meshes:
            mesh.edges(ctx, self._wire).render(moderngl.LINES)

    # -- resources ----------------------------------------------------------------
    def _targets_for(self, size: tuple[int, int]) -> _Targets:
        if self._targets is None or self._targets.size != size:
            old, self._targets = self._targets, _Targets(self.ctx, size)
            if old is not None:
                # moderngl rebinds the last bound framebuffer after creating one: never
                # leave a deleted one bound (GL_INVALID_OPERATION on the next creation)
                self._targets.out_fbo.use()
                old.release()
        return self._targets

    def _make_texture(self, image: np.ndarray) -> moderngl.Texture:
        h, w = image.shape[:2]
        tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(premultiply(image)))
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = False  # clamp to edge
        return tex

    def _texture(self, key: str, image: np.ndarray) -> moderngl.Texture:
        """Cached texture of ``key``; re-uploaded when the array object or shape changes."""
        entry = self._textures.get(key)
        if entry is not None and entry[0] is image and entry[0].shape == image.shape:
            return entry[1]
        if entry is not None:
            entry[1].release()
        tex = self._make_texture(image)
        self._textures[key] = (image, tex)  # holding the array keeps its id unique
        return tex

    def _background(self, background: np.ndarray) -> moderngl.Texture:
        if background.shape[:2] != (1, 1):
            return self._texture("\0background", background)
        self._bg_color.write(premultiply(background).tobytes())
        return self._bg_color

    def _upload(self, layer: DrawLayer, z: np.ndarray) -> _Mesh:
        """Write the layer's vertices into its cached buffers (index buffers kept)."""
        h, w = layer.image.shape[:2]
        data = np.empty((len(z), 5), np.float32)
        data[:, 0:2] = layer.deformed
        data[:, 2:4] = (np.asarray(layer.rest, np.float64) - layer.offset) / (w, h)
        data[:, 4] = z
        tri = np.asarray(layer.triangles)
        mesh = self._meshes.get(layer.key)
        if mesh is None or not mesh.fits(tri, data.nbytes):
            if mesh is not None:
                mesh.release()
            mesh = self._meshes[layer.key] = _Mesh(
                self.ctx, tri, data.nbytes, (self._peel_first, self._peel_next))
        mesh.vbo.write(data)
        return mesh
