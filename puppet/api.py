"""The Python API: ``puppet.load_scene(path) -> Scene`` with ``render`` and ``mesh``."""
from __future__ import annotations

import numpy as np

from puppet.scene.document import Document

_compositor = None


def compositor():
    """The process's compositor (one EGL context, one GL thread), created on first use."""
    global _compositor
    if _compositor is None:
        from puppet.render.compositor import Compositor

        _compositor = Compositor()
    return _compositor


class Scene(Document):
    """A loaded scene that can also draw itself."""

    def render(self, pose: str | None = None, time: float | None = None, *, size: tuple[int, int] | None = None,
               wireframe: bool = False) -> np.ndarray:
        """Draw a pose (or a time on the animation).

        Returns
        -------
        (H, W, 4) uint8 RGBA array (straight alpha), H x W = ``size`` or the canvas.
        """
        from puppet.render.compositor import DrawLayer

        res = self.layers(pose, time)
        draw = [DrawLayer(key=f"{id(self)}:{r.name}", image=im.rgba, offset=im.offset, rest=r.rest,
                          deformed=r.deformed, triangles=r.triangles, depth=r.depth)
                for r, im in zip(res, self.images)]
        return compositor().render(draw, self.canvas, size=size, background=self.background(),
                                   wireframe=wireframe)


def load_scene(path: str) -> Scene:
    """Read and validate a scene file; raises :class:`puppet.SceneError`."""
    return Scene.load(path)
