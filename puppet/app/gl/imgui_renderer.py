"""Dear ImGui (imgui-bundle) on moderngl: draws ImGui's draw lists with the window's
context and feeds it pyglet input. No PyOpenGL.

ImGui 1.92 manages its textures itself (``RendererHasTextures``): every frame the
renderer creates, updates or destroys the textures that ``platform_io.textures`` asks
for (the font atlas grows as glyphs are used). The app's own textures (layer
thumbnails) are registered with :meth:`ImGuiRenderer.register` and drawn with
``imgui.image(renderer.ref(tex), size)``.
"""
from __future__ import annotations

import ctypes

import moderngl
import numpy as np
from imgui_bundle import imgui

from puppet.render.programs import load_program


class ImGuiRenderer:
    """Draw ImGui frames into the current framebuffer of ``ctx``.

    Parameters
    ----------
    ctx : moderngl.Context
        The window's context (current on this thread).
    """

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        io = imgui.get_io()
        io.backend_flags |= imgui.BackendFlags_.renderer_has_textures
        limit = int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 4096))
        pio = imgui.get_platform_io()
        pio.renderer_texture_max_width = limit
        pio.renderer_texture_max_height = limit
        self.prog = load_program(ctx, "app_imgui")
        self.prog["u_texture"].value = 0
        self.vbo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.ibo = ctx.buffer(reserve=1 << 15, dynamic=True)
        fmt = "2f 2f 4f1"
        assert imgui.VERTEX_SIZE == 20, imgui.VERTEX_SIZE
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, fmt, "in_pos", "in_uv", "in_color")],
                                    index_buffer=self.ibo, index_element_size=imgui.INDEX_SIZE)
        self.textures: dict[int, moderngl.Texture] = {}  # ImTextureID -> texture

    # -- textures ----------------------------------------------------------------
    def register(self, tex: moderngl.Texture) -> int:
        """Make ``tex`` drawable by ImGui; returns its ImTextureID."""
        self.textures[tex.glo] = tex
        return tex.glo

    def unregister(self, tex: moderngl.Texture) -> None:
        self.textures.pop(tex.glo, None)

    @staticmethod
    def ref(tex: moderngl.Texture) -> imgui.ImTextureRef:
        return imgui.ImTextureRef(tex.glo)

    def _update_textures(self) -> None:
        for t in imgui.get_platform_io().textures:
            status = t.status
            if status == imgui.ImTextureStatus.ok:
                continue
            if status == imgui.ImTextureStatus.want_create:
                pixels = np.asarray(t.get_pixels_array(), np.uint8).reshape(t.height, t.width, 4)
                tex = self.ctx.texture((t.width, t.height), 4, pixels.tobytes())
                tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
                tex.repeat_x = tex.repeat_y = False
                t.set_tex_id(self.register(tex))
                t.status = imgui.ImTextureStatus.ok
            elif status == imgui.ImTextureStatus.want_updates:
                tex = self.textures[t.tex_id]
                pixels = np.asarray(t.get_pixels_array(), np.uint8).reshape(t.height, t.width, 4)
                for r in t.updates:
                    block = np.ascontiguousarray(pixels[r.y:r.y + r.h, r.x:r.x + r.w])
                    tex.write(block.tobytes(), viewport=(r.x, r.y, r.w, r.h))
                t.status = imgui.ImTextureStatus.ok
            elif status == imgui.ImTextureStatus.want_destroy:
                tex = self.textures.pop(t.tex_id, None)
                if tex is not None:
                    tex.release()
                t.set_tex_id(0)
                t.status = imgui.ImTextureStatus.destroyed

    # -- drawing -----------------------------------------------------------------
    def render(self, draw_data: imgui.ImDrawData, fb_size: tuple[int, int]) -> None:
        """Draw one frame's ``draw_data`` over the current framebuffer (size ``fb_size``)."""
        self._update_textures()
        ctx = self.ctx
        w, h = draw_data.display_size.x, draw_data.display_size.y
        if w <= 0 or h <= 0:
            return
        fw, fh = fb_size
        sx, sy = fw / w, fh / h
        ctx.viewport = (0, 0, fw, fh)
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA,
                          moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
        ctx.blend_equation = moderngl.FUNC_ADD
        self.prog["u_scale"].value = (2.0 / w, 2.0 / h)
        ctx.scissor = None
        for dl in draw_data.cmd_lists:
            nv, ni = dl.vtx_buffer.size(), dl.idx_buffer.size()
            if not ni:
                continue
            self._write(self.vbo, dl.vtx_buffer.data_address(), nv * imgui.VERTEX_SIZE)
            self._write(self.ibo, dl.idx_buffer.data_address(), ni * imgui.INDEX_SIZE)
            for cmd in dl.cmd_buffer:
                x0, y0, x1, y1 = cmd.clip_rect.x, cmd.clip_rect.y, cmd.clip_rect.z, cmd.clip_rect.w
                x0, y0 = max(x0, 0.0), max(y0, 0.0)
                x1, y1 = min(x1, w), min(y1, h)
                if x1 <= x0 or y1 <= y0 or cmd.elem_count == 0:
                    continue
                tex = self.textures.get(cmd.tex_ref.get_tex_id())
                if tex is None:
                    continue
                tex.use(0)
                ctx.scissor = (int(x0 * sx), int(fh - y1 * sy), int((x1 - x0) * sx + 0.5),
                               int((y1 - y0) * sy + 0.5))
                self.vao.render(moderngl.TRIANGLES, vertices=cmd.elem_count, first=cmd.idx_offset)
        ctx.scissor = None
        ctx.disable(moderngl.BLEND)

    @staticmethod
    def _write(buf: moderngl.Buffer, address: int, nbytes: int) -> None:
        if buf.size < nbytes:
            buf.orphan(max(nbytes, 2 * buf.size))
        buf.write((ctypes.c_char * nbytes).from_address(address))

    def release(self) -> None:
        for t in imgui.get_platform_io().textures:
            if t.status != imgui.ImTextureStatus.destroyed and t.tex_id:
                tex = self.textures.pop(t.tex_id, None)
                if tex is not None:
                    tex.release()
                t.set_tex_id(0)
                t.status = imgui.ImTextureStatus.destroyed
        for obj in (self.vao, self.vbo, self.ibo):
            obj.release()
