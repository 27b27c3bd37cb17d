"""Creation of the offscreen OpenGL context the renderer draws with.

puppet renders headless through EGL (Mesa llvmpipe on machines without a GPU, the
driver of the GPU where there is one); no X server and no window are needed.

Threading
---------
OpenGL contexts are bound to one thread. Create the context, every object made from it
(textures, buffers, programs, a :class:`~puppet.render.compositor.Compositor`) and
every draw call on **one** thread. A context used from a thread where it is not
current, or objects created while another context is current, silently give garbage
pixels, with no error raised. Run rendering in a dedicated worker thread if the caller
is multi-threaded, and hand it arrays through a queue.

A :class:`~puppet.render.compositor.Compositor` created without a context owns one and
makes it current only for the duration of each of its calls (restoring whatever was
current before), so several compositors can share a thread.

Do not mix EGL with GLX contexts in one process. Inside a pyglet window use the
window's context instead (``moderngl.create_context()`` once, then
``moderngl.get_context()``) and pass it to the compositor.
"""
from __future__ import annotations

import moderngl

#: Minimum OpenGL version the shaders need (GLSL ``#version 330 core``).
GL_REQUIRE = 330


def create_context(*, require: int = GL_REQUIRE) -> moderngl.Context:
    """Create a standalone (offscreen) OpenGL core context through EGL.

    Parameters
    ----------
    require : int, optional
        Minimum OpenGL version as an integer, ``330`` for 3.3 (the default).

    Returns
    -------
    moderngl.Context
        A new context, current on the calling thread; release it with
        ``ctx.release()`` when done. The first context in a process takes ~0.3 s on
        llvmpipe, later ones a few ms.

    Raises
    ------
    RuntimeError
        When no EGL display or no context of the required version can be created
        (``moderngl``/``glcontext`` raise their own exception types, re-raised here with
        the cause attached).

    Notes
    -----
    The context belongs to the calling thread: see the module docstring.
    """
    try:
        return moderngl.create_standalone_context(require=require, backend="egl")
    except Exception as exc:  # glcontext raises bare Exception subclasses
        raise RuntimeError(f"cannot create an EGL OpenGL {require // 100}.{require % 100 // 10} "
                           f"context: {exc}") from exc
