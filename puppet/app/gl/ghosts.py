"""The onion skin as drawn (GL thread, :class:`GhostRenderer`): each ghost is composited
by the same compositor as the canvas into a texture at window resolution and drawn tinted
(red before, green after) at a lower opacity, behind the current frame. Which times are
ghosted is :mod:`puppet.app.model.onion`.
"""
from __future__ import annotations

import moderngl
import numpy as np

from puppet.app.model.onion import DEFAULTS
from puppet.render.layers import DrawLayer
from puppet.render.programs import load_program


class GhostRenderer:
    """Draws the onion skin's ghosts (GL thread only), composited by ``compositor``."""

    #: how much of a ghost's colour is the tint (the rest is its own colours)
    TINT = 0.8

    def __init__(self, ctx: moderngl.Context, compositor):
        self.ctx, self.compositor = ctx, compositor
        self.prog = load_program(ctx, "app_quad", defines={"GHOST": 1})
        self.vbo = ctx.buffer(reserve=16 * 4)
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, "2f 2f", "in_pos", "in_uv")])
        self.textures: dict = {}  # key -> texture, the ghosts of the last frame drawn
        self.composites = 0

    def _texture(self, layers, images, view, rect, hidden) -> tuple[tuple, moderngl.Texture]:
        x0, y0, x1, y1 = rect
        key = (id(layers), view.scale, tuple(view.origin), rect, frozenset(hidden))
        entry = self.textures.get(key)
        if entry is not None and entry[0] is layers:
            return key, entry[1]
        size = (max(1, int(x1 - x0)), max(1, int(y1 - y0)))
        origin = np.asarray(view.origin, float) - (x0, y0)
        draw = [DrawLayer(key=r.name, image=im.drawn[0], offset=im.drawn[1], rest=r.rest,
                          deformed=np.asarray(r.deformed, float) * view.scale + origin,
                          triangles=r.triangles, depth=r.depth)
                for r, im in zip(layers, images) if r.name not in hidden]
        tex = self.ctx.texture(size, 4)
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.compositor.draw(draw, size, target=tex, background=(0, 0, 0, 0))
        self.ctx.error  # noqa: B018 - clear a flag the compositor left
        self.ctx.screen.use()
        self.composites += 1
        self.textures[key] = (layers, tex)
        return key, tex

    def draw(self, snap, view, rect, screen, *, hidden=frozenset(), opacity: float = 0.35,
             colours=None) -> None:
        """Draw ``snap.ghosts`` over what is on the screen now, inside window rect ``rect``
        (x0, y0, x1, y1); ``colours``: {"before": rgb, "after": rgb} (0..1)."""
        colours = colours or {"before": DEFAULTS["before"], "after": DEFAULTS["after"]}
        used = set()
        # farthest first, so the nearest ghosts are on top
        for side, weight, layers in sorted(snap.ghosts, key=lambda g: g[1]):
            key, tex = self._texture(layers, snap.images, view, rect, hidden)
            used.add(key)
            ctx = self.ctx
            ctx.screen.use()
            ctx.enable_only(moderngl.BLEND)
            ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
            tex.use(0)
            self.prog["u_texture"].value = 0
            self.prog["u_screen"].value = tuple(map(float, screen))
            self.prog["u_tint"].value = tuple(map(float, colours[side]))
            self.prog["u_mix"].value = self.TINT
            self.prog["u_opacity"].value = float(np.clip(opacity * (0.4 + 0.6 * weight), 0.0, 1.0))
            x0, y0, x1, y1 = rect
            self.vbo.write(np.array([x0, y0, 0, 0, x1, y0, 1, 0, x0, y1, 0, 1, x1, y1, 1, 1], np.float32))
            self.vao.render(moderngl.TRIANGLE_STRIP)
        for key, (_, tex) in list(self.textures.items()):  # forget ghosts no longer shown
            if key not in used:
                tex.release()
                del self.textures[key]

    def under(self, app):
        """``canvas.draw``'s ``under``: the ghosts of ``app``'s snapshot with its settings."""
        t = app.timeline

        def draw(screen, view, rect):
            self.draw(app.snap, view, rect, screen, hidden=app.hidden, opacity=float(t.onion["opacity"]),
                      colours={"before": t.onion["before"], "after": t.onion["after"]})
        return draw

    def release(self) -> None:
        for _, tex in self.textures.values():
            tex.release()
        self.textures.clear()
        self.vao.release()
        self.vbo.release()
