"""The GL passes of one composited frame (see :mod:`puppet.render.compositor` for the
method): background, opaque pass, edge pass (K-buffer or A-buffer), wireframe, and the
read-back. Holds the programs and the small buffers the passes share."""
from __future__ import annotations

import moderngl
import numpy as np

from .gpu import FrameTargets, LayerMesh
from .layers import (ALPHA_MIN, ALPHA_OPAQUE, TIE_BIAS, Z_MAX, Z_MIN, depth_window,
                     premultiply)
from .programs import load_program, set_uniform

#: Translucent fragments in front of the nearest opaque one that the K-buffer holds exactly.
K = 3
#: Translucent fragments per pixel the A-buffer sorts (the nearest ones are kept).
MAX_FRAGMENTS = 16
#: Most A-buffer nodes (16 bytes each) allocated.
MAX_NODES = 1 << 23
#: Wireframe colour, straight RGBA in 0..1.
WIRE_COLOR = (0.08, 0.08, 0.08, 0.7)
_PASSES = {"opaque": "OPAQUE_PASS", "kbuffer": "KBUFFER_PASS", "append": "APPEND_PASS",
           "resolve": "RESOLVE_PASS", "blend": "BLEND_PASS"}

#: (list position, mesh, texture) of one layer in a frame
Draw = tuple[int, LayerMesh, moderngl.Texture]


class Passes:
    """Programs, counters and A-buffer nodes of one context, and the frame's passes.

    Parameters
    ----------
    ctx : moderngl.Context
        Current context (OpenGL 4.3).
    kbuffer : bool
        Compile the K-buffer pass (the context has framebuffer fetch).
    """

    def __init__(self, ctx: moderngl.Context, *, kbuffer: bool):
        self.ctx = ctx
        consts = {"ALPHA_MIN": ALPHA_MIN, "ALPHA_OPAQUE": ALPHA_OPAQUE, "Z_MIN": Z_MIN,
                  "Z_MAX": Z_MAX, "K": K, "MAX_FRAGMENTS": MAX_FRAGMENTS}
        self.programs = {name: load_program(ctx, "layer", defines={**consts, define: 1})
                         for name, define in _PASSES.items() if name != "kbuffer" or kbuffer}
        self.wire = load_program(ctx, "wire")
        self._background = load_program(ctx, "background")
        self._straight = load_program(ctx, "straight")
        self._fullscreen = {p: ctx.vertex_array(p, []) for p in (self._background, self._straight)}
        self.counters = ctx.buffer(reserve=16)  # overflow, nodes used, nodes lost, -
        self.nodes: moderngl.Buffer | None = None
        self._stamp = 0

    # -- the frame ----------------------------------------------------------------
    def frame(self, draws: list[Draw], canvas, targets: FrameTargets, background: np.ndarray,
              background_texture: moderngl.Texture | None, *, method: str, wireframe: bool,
              flip: bool) -> str:
        """Draw one frame into ``targets.main`` (premultiplied), nothing read back.

        Returns the edge method used: "abuffer" also when the K-buffer's attachments
        (32 more bytes a pixel) cannot be allocated at this size. ``method="blend"`` (drag
        previews, not exact) blends the edge fragments unsorted (:meth:`_blend_edges`).
        """
        ctx = self.ctx
        cw, ch = float(canvas[0]), float(canvas[1])
        ndc = (2.0 / cw, -2.0 / ch, -1.0, 1.0) if flip else (2.0 / cw, 2.0 / ch, -1.0, -1.0)
        live = [d for d in draws if d[1].vaos]
        hi, inv = depth_window(min((m.lo for _, m, _ in live), default=0.0),
                               max((m.hi for _, m, _ in live), default=0.0))
        depth = {i: (hi, inv, i * TIE_BIAS) for i, _, _ in live}
        live.sort(key=lambda d: (hi - d[1].mean) * inv - d[0] * TIE_BIAS)  # nearest first
        for prog in (*self.programs.values(), self.wire):
            set_uniform(prog, "u_ndc", ndc)

        self._draw_background(targets, background, background_texture, flip)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="  # exact ties: the later triangle wins
        self._draw_layers("opaque", live, depth)
        ctx.depth_func = "<"   # edge fragments strictly in front of the opaque depth
        self.counters.write(bytes(16))
        self.counters.bind_to_storage_buffer(0)
        if method == "blend":
            self._blend_edges(live, depth, targets)
        elif method == "kbuffer":
            try:
                kbuffer_fbo = targets.kbuffer()
            except moderngl.Error:
                method = "abuffer"
                self.ctx.error  # noqa: B018 - the failed allocation's flag
        if method == "kbuffer":
            kbuffer_fbo.use()
            # a stamp never seen before by these targets: 2^32 / 4 frames before a wrap
            self._stamp = (self._stamp + K + 1) % (1 << 32) or K + 1
            set_uniform(self.programs["kbuffer"], "u_frame", self._stamp)
            self._draw_layers("kbuffer", live, depth)
        elif method == "abuffer":
            scale = (targets.size[0] / cw, targets.size[1] / ch)
            capacity = self.ensure_nodes(sum(m.fragment_bound(scale) for _, m, _ in live))
            append_fbo, heads = targets.abuffer()
            heads.bind_to_image(0, read=True, write=True)
            self.nodes.bind_to_storage_buffer(1)
            set_uniform(self.programs["append"], "u_capacity", capacity)
            append_fbo.use()
            targets.heads_dirty = True
            self._draw_layers("append", live, depth, order=True)
            ctx.memory_barrier()
            targets.test_fbo.use()
            self._blend_over()
            self._draw_layers("resolve", live, depth)
            targets.heads_dirty = False
            ctx.memory_barrier()
        if wireframe:
            self._draw_wireframe(live, targets)
        return method

    def _draw_layers(self, name: str, live: list[Draw], depth, *, order: bool = False) -> None:
        program = self.programs[name]
        for position, (i, mesh, texture) in enumerate(live):
            vao = mesh.vaos.get(name)
            if vao is None:
                continue
            set_uniform(program, "u_depth", depth[i])
            if order:
                set_uniform(program, "u_order", position << 20)
            texture.use(0)
            vao.render(moderngl.TRIANGLES)

    def _blend_edges(self, live: list[Draw], depth, targets: FrameTargets) -> None:
        """The preview edge pass: edge fragments in front of the opaque depth blended over
        the frame, layers farthest first, no depth write, no sorting within a pixel."""
        targets.test_fbo.use()
        self._blend_over()
        self._draw_layers("blend", live[::-1], depth)

    def _draw_background(self, targets: FrameTargets, background, texture, flip) -> None:
        targets.write_fbo.use()
        if texture is None:
            r, g, b, a = (premultiply(background)[0, 0] / 255.0).tolist()
            targets.write_fbo.clear(r, g, b, a, depth=1.0)
            return
        targets.write_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.ctx.enable_only(moderngl.NOTHING)
        texture.use(0)
        set_uniform(self._background, "u_flip", 1.0 if flip else 0.0)
        self._fullscreen[self._background].render(moderngl.TRIANGLES, vertices=3)

    def _blend_over(self) -> None:
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_equation = moderngl.FUNC_ADD
        self.ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA

    def _draw_wireframe(self, live: list[Draw], targets: FrameTargets) -> None:
        targets.test_fbo.use()
        self.ctx.enable_only(moderngl.NOTHING)
        self._blend_over()
        self.ctx.line_width = 1.0
        r, g, b, a = WIRE_COLOR
        set_uniform(self.wire, "u_color", (r * a, g * a, b * a, a))
        for _, mesh, _ in live:
            vao = mesh.wire(self.ctx, self.wire)
            if vao is not None:
                vao.render(moderngl.LINES)

    def read(self, targets: FrameTargets, straight: bool) -> np.ndarray:
        """The composite as (H, W, 4) uint8, row 0 first; straight alpha when asked
        (one full-screen pass), else as stored (premultiplied)."""
        fbo = targets.write_fbo
        if straight:
            fbo = targets.output()
            fbo.use()
            self.ctx.enable_only(moderngl.NOTHING)
            targets.main.use(0)
            self._fullscreen[self._straight].render(moderngl.TRIANGLES, vertices=3)
        w, h = targets.size
        out = np.empty((h, w, 4), np.uint8)
        fbo.read_into(out, components=4)
        return out

    # -- buffers ------------------------------------------------------------------
    def read_counters(self) -> tuple[int, int, int]:
        """(overflow, nodes used, nodes lost) of the last frame; waits for that frame."""
        overflow, used, lost, _ = np.frombuffer(self.counters.read(), np.uint32).tolist()
        return overflow, used, lost

    def ensure_nodes(self, bound: float) -> int:
        """Make room for ``bound`` A-buffer nodes (capped); return the capacity."""
        need = int(min(max(bound, 1024), MAX_NODES))
        if self.nodes is None or self.nodes.size < need * 16:
            self.grow(need)
        return self.nodes.size // 16

    def grow(self, need: int) -> bool:
        """Make room for ``need`` nodes with slack; False when already there or capped."""
        have = 0 if self.nodes is None else self.nodes.size // 16
        new = int(min(MAX_NODES, max(need * 3 // 2, 1024)))
        if need <= have or new <= have:
            return False
        if self.nodes is not None:
            self.nodes.release()
        self.nodes = self.ctx.buffer(reserve=new * 16)
        return True

    def release(self) -> None:
        for obj in (*self._fullscreen.values(), self.counters, self.nodes):
            if obj is not None:
                obj.release()
        self._fullscreen, self.nodes = {}, None
