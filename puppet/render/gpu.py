"""GL resources of the compositor: the buffers of one uploaded layer, and the render
targets of one output size. Used by :class:`puppet.render.compositor.Compositor` only."""
from __future__ import annotations

import moderngl
import numpy as np

from .layers import DrawLayer, classify_triangles, fragment_bound, mesh_edges, texture_uv

OWN = object()  # tag in the .extra of the compositor's own framebuffers
#: (internal format, format, type) of the RGBA textures of the targets, by moderngl dtype:
#: RGBA8, RGBA16F, RGBA32UI (the K-buffer's attachments)
FORMATS = {"f1": (0x8058, 0x1908, 0x1401), "f2": (0x881A, 0x1908, 0x140B), "u4": (0x8D70, 0x8D99, 0x1405)}


class LayerMesh:
    """Buffers of one layer key: positions and depths rewritten on every change, texture
    coordinates and index buffers kept while the rest mesh and image stay the same.

    Attributes
    ----------
    posz : ndarray, shape (n, 3), float32
        CPU copy of the vertex buffer: deformed x, y and depth.
    vaos : dict of str to moderngl.VertexArray
        One per pass: ``opaque`` draws every non-empty triangle, the edge passes
        (``kbuffer``, ``append``, ``resolve``) the triangles that can be translucent.
    lo, hi, mean : float
        Depth range and mean of the vertices.
    """

    def __init__(self, ctx: moderngl.Context, layer: DrawLayer,
                 programs: dict[str, moderngl.Program]):
        self.image = layer.image
        self._sources = (layer.rest, layer.triangles)  # identity: the cheap fits() test
        self.offset = tuple(float(v) for v in layer.offset)
        self.rest = np.array(layer.rest, np.float64)
        self.triangles = np.array(layer.triangles, np.int32).reshape(-1, 3)
        uv = texture_uv(self.rest, self.offset, layer.image.shape)
        edge, empty = layer.classes or classify_triangles(layer.image, uv, self.triangles)
        self.edge_triangles = self.triangles[edge]
        drawn = self.triangles[~empty]
        self.counts = {"opaque": len(drawn), "edge": len(self.edge_triangles)}
        self._drawn = drawn
        self._extra: dict[str, moderngl.VertexArray] = {}  # other programs' arrays of the drawn triangles
        self.posz = np.zeros((len(self.rest), 3), np.float32)
        self.vbo = ctx.buffer(reserve=max(self.posz.nbytes, 12))
        self.uv = ctx.buffer(uv.tobytes() or bytes(8))
        self._buffers = [self.vbo, self.uv]
        self.vaos: dict[str, moderngl.VertexArray] = {}
        for name, program in programs.items():
            tri = drawn if name == "opaque" else self.edge_triangles
            if len(tri):
                self.vaos[name] = self._vertex_array(ctx, program, tri)
        self.lo = self.hi = self.mean = 0.0
        self._wire = None

    def _vertex_array(self, ctx, program, triangles) -> moderngl.VertexArray:
        ibo = ctx.buffer(np.ascontiguousarray(triangles, np.int32))
        self._buffers.append(ibo)
        content = [(self.vbo, "2f 1f", "in_pos", "in_depth")]
        if program.get("in_uv", None) is not None:
            content.append((self.uv, "2f", "in_uv"))
        return ctx.vertex_array(program, content, index_buffer=ibo, index_element_size=4)

    def drawn_array(self, ctx: moderngl.Context, name: str, program: moderngl.Program):
        """The vertex array of every non-empty triangle for another ``program`` (made on
        first use, kept with the mesh); None when the layer has none."""
        vao = self._extra.get(name)
        if vao is None and len(self._drawn):
            vao = self._extra[name] = self._vertex_array(ctx, program, self._drawn)
        return vao

    def fits(self, layer: DrawLayer) -> bool:
        """True when ``layer`` has this mesh's image object, offset, rest and triangles
        (the same arrays, or equal ones)."""
        if layer.image is not self.image or tuple(float(v) for v in layer.offset) != self.offset:
            return False
        if layer.rest is self._sources[0] and layer.triangles is self._sources[1]:
            return True
        if (np.shape(layer.rest) == self.rest.shape
                and np.array_equal(layer.triangles, self.triangles)
                and np.array_equal(layer.rest, self.rest)):
            self._sources = (layer.rest, layer.triangles)
            return True
        return False

    def write(self, deformed: np.ndarray | None = None, depth: np.ndarray | None = None) -> None:
        """Write new positions and/or depths into the vertex buffer (no re-creation)."""
        if deformed is not None:
            self.posz[:, :2] = deformed
        if depth is not None:
            self.posz[:, 2] = depth
            if len(depth):
                self.lo, self.hi = float(np.min(depth)), float(np.max(depth))
                self.mean = float(np.mean(depth))
        if len(self.posz):
            self.vbo.write(self.posz)

    def fragment_bound(self, scale: tuple[float, float]) -> float:
        """Most fragments the edge triangles can give at this output scale."""
        return fragment_bound(self.posz[:, :2], self.edge_triangles, scale)

    def wire(self, ctx: moderngl.Context, program: moderngl.Program) -> moderngl.VertexArray | None:
        """Vertex array of the mesh's unique edges as lines (made on first use)."""
        if self._wire is None and len(self.triangles):
            ibo = ctx.buffer(mesh_edges(self.triangles))
            self._buffers.append(ibo)
            self._wire = ctx.vertex_array(program, [(self.vbo, "2f 4x", "in_pos")],
                                          index_buffer=ibo, index_element_size=4)
        return self._wire

    def release(self) -> None:
        for vao in (*self.vaos.values(), *self._extra.values(), self._wire):
            if vao is not None:
                vao.release()
        for buf in self._buffers:
            buf.release()
        self.vaos, self._extra, self._wire, self._buffers = {}, {}, None, []


class FrameTargets:
    """Render targets of one output size: the composite (premultiplied, RGBA8 or
    half-float, or an RGBA8 texture given by the caller) with its depth buffer, and, made
    on first use, the K-buffer attachments, the A-buffer's list heads and the
    straight-alpha RGBA8 output."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int],
                 main: moderngl.Texture | None = None, dtype: str = "f1", unlocked=None):
        self.ctx, self.size = ctx, size
        self._unlocked = unlocked  # context.UnlockedGL: big textures made without the GIL held
        self._names: list[int] = []  # GL textures made through it (deleted on release)
        self.own_main = main is None
        self.dtype = dtype if main is None else "f1"
        self.main = self._texture(dtype) if main is None else main
        self.depth = ctx.depth_renderbuffer(size)
        self.write_fbo = self._fbo([self.main], self.depth)  # depth test + write
        self.test_fbo = self._fbo([self.main], self.depth)   # depth test, no write
        self.test_fbo.depth_mask = False
        self.kbuffer_fbo = None
        self.kbuffer_failed = False
        self.append_fbo = self.heads = None
        self.heads_dirty = False
        self.out_fbo = None
        self._objects = [self.depth]

    def _fbo(self, colors, depth) -> moderngl.Framebuffer:
        fbo = self.ctx.framebuffer(colors, depth)
        fbo.extra = OWN  # never rebound as "the caller's" framebuffer
        return fbo

    def kbuffer(self) -> moderngl.Framebuffer:
        """Framebuffer [composite, packed colours, packed depths + stamp] sharing the
        depth buffer (the K-buffer pass, K = 3)."""
        if self.kbuffer_fbo is None:
            if self.kbuffer_failed:
                raise moderngl.Error("no memory for the K-buffer at this size")
            w, h = self.size
            # the packed depths hold the stamp: 0, stale from the first frame on. The packed
            # colours are read only under a stamp of this frame, so they start undefined:
            # not uploading their 16 bytes a pixel saves ~0.08 s of llvmpipe at 4000x4000
            contents = (None, np.zeros(w * h * 4, np.uint32))
            extra = []
            try:
                for data in contents:
                    extra.append(self._texture("u4", data))
                    self._objects.append(extra[-1])
            except moderngl.Error:
                self.kbuffer_failed = True
                raise
            self.kbuffer_fbo = self._fbo([self.main, *extra], self.depth)
            self.kbuffer_fbo.depth_mask = False
        return self.kbuffer_fbo

    def _texture(self, dtype: str, data=None) -> moderngl.Texture:
        """An RGBA texture of the targets' size (from ``data`` when given), as
        ``ctx.texture`` makes it; without the GIL held when the context allows: the same
        GL texture from the same call, with moderngl's filter (linear for floats; an
        integer texture here is never sampled)."""
        if self._unlocked is None:
            return self.ctx.texture(self.size, 4, data, dtype=dtype)
        self._names.append(self._unlocked.texture(self.size, FORMATS[dtype], data))
        tex = self.ctx.external_texture(self._names[-1], self.size, 4, 0, dtype)
        if dtype.startswith("f"):
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        return tex

    def abuffer(self) -> tuple[moderngl.Framebuffer, moderngl.Texture]:
        """Depth-only framebuffer for appending, and the list-head image, all zero (the
        resolve pass empties every head it reads; ``heads_dirty`` marks a frame cut short
        between the two passes)."""
        w, h = self.size
        if self.append_fbo is None:
            self.heads = self.ctx.texture(self.size, 1, np.zeros(w * h, np.uint32), dtype="u4")
            self._objects.append(self.heads)
            self.append_fbo = self._fbo([], self.depth)
            self.append_fbo.depth_mask = False
        elif self.heads_dirty:
            self.heads.write(np.zeros(w * h, np.uint32))
        self.heads_dirty = False
        return self.append_fbo, self.heads

    def output(self) -> moderngl.Framebuffer:
        """Framebuffer of a straight-alpha RGBA8 copy of the composite."""
        if self.out_fbo is None:
            tex = self._texture("f1")
            self._objects.append(tex)
            self.out_fbo = self._fbo([tex], None)
        return self.out_fbo

    def release(self) -> None:
        for fbo in (self.write_fbo, self.test_fbo, self.kbuffer_fbo, self.append_fbo,
                    self.out_fbo):
            if fbo is not None:
                fbo.release()
        for obj in self._objects:
            obj.release()
        if self.own_main:
            self.main.release()
        if self._names:
            self._unlocked.delete(self._names)
        self._objects, self._names = [], []
