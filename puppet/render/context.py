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

import ctypes
import weakref

import moderngl

#: Minimum OpenGL version the shaders need (GLSL ``#version 430 core``: storage buffers,
#: image atomics and early fragment tests for the compositor).
GL_REQUIRE = 430


def create_context(*, require: int = GL_REQUIRE) -> moderngl.Context:
    """Create a standalone (offscreen) OpenGL core context through EGL.

    Parameters
    ----------
    require : int, optional
        Minimum OpenGL version as an integer, ``430`` for 4.3 (the default).

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
        ctx = moderngl.create_standalone_context(require=require, backend="egl")
    except Exception as exc:  # glcontext raises bare Exception subclasses
        raise RuntimeError(f"cannot create an EGL OpenGL {require // 100}.{require % 100 // 10} "
                           f"context: {exc}") from exc
    handle = _egl_current()  # the new context is current: remember its EGL handle
    if handle:
        _handles[ctx] = handle
    return ctx


_handles: "weakref.WeakKeyDictionary[moderngl.Context, int]" = weakref.WeakKeyDictionary()
_egl_get_current = None


def _egl_current() -> int | None:
    """The calling thread's current EGL context handle (None: none, or no libEGL)."""
    global _egl_get_current
    if _egl_get_current is None:
        try:
            fn = ctypes.CDLL("libEGL.so.1").eglGetCurrentContext
        except (OSError, AttributeError):
            fn = False
        else:
            fn.restype, fn.argtypes = ctypes.c_void_p, []
        _egl_get_current = fn
    return _egl_get_current() if _egl_get_current else None


def is_current(ctx: moderngl.Context) -> bool:
    """True when ``ctx``, made by :func:`create_context`, is current on this thread.

    ``with ctx:`` must not be nested for one context: moderngl's exit then leaves no
    context current. Callers that switch contexts check this first.
    """
    handle = _handles.get(ctx)
    return handle is not None and _egl_current() == handle


class UnlockedGL:
    """The few GL calls that make a big texture, through ctypes, which lets go of Python's
    GIL while the driver allocates and zeroes (moderngl keeps it through every call): a
    thread that builds a scene's rig runs on meanwhile. Textures made here are the
    caller's to delete (:meth:`delete`; a moderngl ``external_texture`` around one does
    not). Made by :func:`unlocked_gl` for a context of :func:`create_context` only."""

    TEXTURE_2D, TEXTURE_BINDING_2D = 0x0DE1, 0x8069

    def __init__(self, proc):
        U, I, P = ctypes.c_uint, ctypes.c_int, ctypes.c_void_p
        self._gen = ctypes.CFUNCTYPE(None, I, ctypes.POINTER(U))(proc(b"glGenTextures"))
        self._delete = ctypes.CFUNCTYPE(None, I, ctypes.POINTER(U))(proc(b"glDeleteTextures"))
        self._bind = ctypes.CFUNCTYPE(None, U, U)(proc(b"glBindTexture"))
        self._get = ctypes.CFUNCTYPE(None, U, ctypes.POINTER(I))(proc(b"glGetIntegerv"))
        self._image = ctypes.CFUNCTYPE(None, U, I, I, I, I, I, U, U, P)(proc(b"glTexImage2D"))

    def texture(self, size: tuple[int, int], formats: tuple[int, int, int], data=None) -> int:
        """A new 2D texture of ``size`` = (w, h) and ``formats`` = (internal format, format,
        type), from the contiguous array ``data`` when given; its GL name. The binding of
        the active texture unit is kept; GL errors are left to the caller's checks."""
        name, bound = ctypes.c_uint(), ctypes.c_int()
        self._get(self.TEXTURE_BINDING_2D, ctypes.byref(bound))
        self._gen(1, ctypes.byref(name))
        self._bind(self.TEXTURE_2D, name.value)
        pointer = None if data is None else data.ctypes.data
        self._image(self.TEXTURE_2D, 0, formats[0], size[0], size[1], 0, formats[1], formats[2], pointer)
        self._bind(self.TEXTURE_2D, bound.value)
        return name.value

    def delete(self, names) -> None:
        names = list(names)
        if names:
            self._delete(len(names), (ctypes.c_uint * len(names))(*names))


def unlocked_gl(ctx: moderngl.Context) -> UnlockedGL | None:
    """:class:`UnlockedGL` for a context made by :func:`create_context`, else None (a
    caller's context, a window's, may not be EGL's; no libEGL, a missing function)."""
    if ctx not in _handles:
        return None
    try:
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetProcAddress.restype, egl.eglGetProcAddress.argtypes = ctypes.c_void_p, [ctypes.c_char_p]

        def proc(name: bytes) -> int:
            address = egl.eglGetProcAddress(name)
            if not address:
                raise AttributeError(name.decode())
            return address
        return UnlockedGL(proc)
    except (OSError, AttributeError):
        return None


def max_output_size(ctx: moderngl.Context) -> int:
    """Largest width or height of a frame ``ctx`` can draw into.

    The smallest of ``GL_MAX_RENDERBUFFER_SIZE``, ``GL_MAX_TEXTURE_SIZE`` (the
    compositor's targets are both) and ``GL_MAX_VIEWPORT_DIMS``; 16384 on llvmpipe.
    """
    with ctx:  # the limits are read from the current context
        info = ctx.info
    dims = info.get("GL_MAX_VIEWPORT_DIMS") or (0, 0)
    limits = [info.get("GL_MAX_RENDERBUFFER_SIZE"), info.get("GL_MAX_TEXTURE_SIZE"), *dims]
    return int(min(v for v in limits if v)) if any(limits) else 0


def output_size_problem(ctx: moderngl.Context, size: tuple[int, int], *, allocate=None) -> str | None:
    """Why ``ctx`` cannot draw a frame of ``size`` = (width, height), or None when it can.

    Checks the size against :func:`max_output_size`, then allocates the frame, so that a
    driver out of memory is found before any frame is drawn: ``allocate()`` when given
    (the compositor's own targets, kept for the frames that follow: see
    :meth:`~puppet.render.compositor.Compositor.reserve`; it raises ``moderngl.Error`` or
    leaves a GL error when it fails), else a throwaway framebuffer with a colour and a
    depth attachment (allocated and released: ~0.12 s of llvmpipe's time at 4000x4000).
    """
    w, h = int(size[0]), int(size[1])
    limit = max_output_size(ctx)
    if limit and max(w, h) > limit:
        return f"this machine's OpenGL draws at most {limit}x{limit}"
    with ctx:
        ctx.error  # clear a stale error flag
        objs = []
        try:
            if allocate is not None:
                allocate()
            else:
                objs.append(ctx.renderbuffer((w, h), 4))
                objs.append(ctx.depth_renderbuffer((w, h)))
                objs.append(ctx.framebuffer(objs[:1], objs[1]))
            error = ctx.error
        except moderngl.Error as exc:
            error = str(exc)
        finally:
            for obj in reversed(objs):
                obj.release()
    if error != "GL_NO_ERROR":
        return f"OpenGL cannot allocate a {w}x{h} frame ({error})"
    return None
