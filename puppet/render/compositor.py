"""Per-pixel depth compositing of textured layer meshes: one opaque pass, then the soft
edges sorted per pixel.

Each layer is a textured triangle mesh with a per-vertex depth (higher = in front),
interpolated across each triangle: which layer is in front is decided per pixel, so a
limb can pass behind the body and in front again, and a layer can overlap itself.
Textures are premultiplied. A frame is:

1. the background (a clear, or a full-screen quad for an image), depth cleared;
2. **opaque pass**: every non-empty triangle, depth test LEQUAL with depth write,
   fragments with alpha < :data:`ALPHA_OPAQUE` discarded. This is a plain depth-tested
   draw: it costs what a frame without any transparency costs;
3. **edge pass**: only the *edge triangles* (those whose texture reach holds a texel with
   alpha < 255, found once per mesh, see :func:`~puppet.render.layers.classify_triangles`),
   early depth test LESS against the opaque depth, fragments with
   :data:`ALPHA_MIN` <= alpha < :data:`ALPHA_OPAQUE` kept. They go either

   * into a per-pixel **K-buffer** (``kbuffer``, needs ``GL_EXT_shader_framebuffer_fetch``,
     which Mesa llvmpipe has): each fragment reads the pixel's K sorted entries and the
     colour found under them, inserts itself and rewrites the composite. Exact up to K
     translucent fragments in front of the nearest opaque one (K = 3); beyond, the two
     farthest are merged and an overflow is counted; or
   * into an **A-buffer** (``abuffer``, any GL 4.3): per-pixel linked lists of nodes in a
     storage buffer, then the edge triangles again, the first fragment at a pixel sorting
     its list (up to :data:`MAX_FRAGMENTS`) and blending it over the opaque colour.

   ``method="auto"`` uses the K-buffer where it exists. :meth:`Compositor.render` reads a
   counter after its read-back (no extra wait) and redraws with the A-buffer when the
   K-buffer overflowed, so its output is always exact; :meth:`Compositor.draw` switches
   to the A-buffer from the next frame on (and back when no pixel needs it).

A drag preview (``preview=True``) replaces the edge pass by one unsorted **blend** pass
(not exact; docs/algorithms.md section 10) and is read back premultiplied, made straight
on the CPU at its translucent pixels only.

No pass waits for the GPU: :meth:`~Compositor.render` reads back once at the end, and
:meth:`~Compositor.draw` reads the previous frame's 16-byte counter when it starts the next.

Tie rule (the CPU reference ``tests/render/reference.py`` follows it):
    * the larger depth is in front;
    * equal depths in two layers: the later layer in the list is in front (each list
      position moves a layer :data:`~puppet.render.layers.TIE_BIAS` of the window depth
      range nearer, so depths closer than that count as equal);
    * equal depths inside one layer (a limb folded over itself at one pin depth): an
      opaque fragment hides the layer's translucent ones; of opaque fragments the later
      triangle wins; translucent ones are composited in triangle order, the later over
      the earlier. Nothing at a tie is dropped, so no background shows through.
"""
from __future__ import annotations

import contextlib
from typing import Sequence

import moderngl
import numpy as np

from .context import GL_REQUIRE, create_context, is_current, unlocked_gl
from .gpu import OWN, FrameTargets, LayerMesh
from .layers import (ALPHA_MIN, ALPHA_OPAQUE, DrawLayer, check_background,  # noqa: F401
                     check_layer, check_vertices, depth_window, mesh_edges, premultiply,
                     unpremultiply_soft)
from .passes import K, MAX_FRAGMENTS, WIRE_COLOR, Draw, Passes  # noqa: F401
from .programs import load_program, set_uniform

#: Render targets kept (per output size, format and caller texture).
KEEP_TARGETS = 3
METHODS = ("auto", "kbuffer", "abuffer")
FETCH = "GL_EXT_shader_framebuffer_fetch"
#: Texture cache key of a background image (NUL-prefixed: not a layer name).
BACKGROUND = "\0background"


class Compositor:
    """Composite :class:`DrawLayer` meshes by per-pixel depth.

    Parameters
    ----------
    ctx : moderngl.Context, optional
        Context to draw with (current on this thread, OpenGL >= 4.3). When None, an EGL
        standalone context is created, owned and released by the compositor.
    method : {"auto", "kbuffer", "abuffer"}
        How soft-edge fragments are sorted (see the module notes). ``"kbuffer"`` raises
        RuntimeError when the context lacks framebuffer fetch.

    Attributes
    ----------
    last_method : str or None
        Edge method of the last frame ("kbuffer" or "abuffer"; "blend" for a preview).
    last_overflow : int
        Fragments (K-buffer) or pixels (A-buffer) beyond K in the last frame that was
        checked (render: always; draw: the previous frame, when the next one starts).

    Notes
    -----
    Use it from the context's thread only. An owned context is made current around each
    call (several compositors can share a thread); a context passed in must be current.
    ``render`` and ``draw`` change GL state (enable flags, blend and depth functions,
    line width, texture unit 0-1, image unit 0, storage bindings 0-1), clear a pending GL
    error first, and rebind the caller's framebuffer if one was bound.
    """

    def __init__(self, ctx: moderngl.Context | None = None, *, method: str = "auto"):
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        self._own_ctx = ctx is None
        self.ctx = create_context() if ctx is None else ctx
        if self.ctx.version_code < GL_REQUIRE:
            raise RuntimeError(f"the compositor needs OpenGL {GL_REQUIRE // 100}."
                               f"{GL_REQUIRE % 100 // 10}, the context has {self.ctx.version_code}")
        self._fetch = FETCH in self.ctx.extensions
        if method == "kbuffer" and not self._fetch:
            raise RuntimeError(f"method 'kbuffer' needs {FETCH}")
        self.method = method
        self.last_method: str | None = None
        self.last_overflow = 0
        self._prefer_abuffer = False
        self._pending: str | None = None  # method of a frame whose counters are unread
        with self._current():
            self._passes: Passes | None = Passes(self.ctx, kbuffer=self._fetch)
        self._textures: dict[str, tuple[np.ndarray, moderngl.Texture]] = {}
        self._meshes: dict[str, LayerMesh] = {}
        self._targets: dict[tuple, FrameTargets] = {}
        self._unlocked = unlocked_gl(self.ctx) if self._own_ctx else None  # big targets made without the GIL
        self._depth_fbo: moderngl.Framebuffer | None = None  # pin_depth's target (its last size)

    # -- public -------------------------------------------------------------------
    def upload(self, layer: DrawLayer) -> None:
        """Upload (or refresh) a layer: texture, mesh buffers, positions and depths.

        The texture is re-uploaded only for a new image array; the index buffers only
        when the rest mesh, offset or image changed; positions and depths are written.
        """
        with self._current():
            self._upload(layer)

    def update(self, key: str, *, deformed: np.ndarray | None = None,
               depth: np.ndarray | None = None) -> None:
        """Write new deformed positions (n, 2) and/or depths (n,) of an uploaded layer:
        one vertex-buffer write, nothing re-created (the cheap path of a drag)."""
        mesh = self._meshes.get(key)
        if mesh is None:
            raise KeyError(f"layer {key!r} is not uploaded")
        deformed, depth = check_vertices(key, len(mesh.posz), deformed, depth)
        with self._current():
            mesh.write(deformed, depth)

    def render(self, layers: Sequence[DrawLayer | str], canvas: tuple[int, int], *,
               size: tuple[int, int] | None = None,
               background: tuple[int, int, int, int] | np.ndarray = (0, 0, 0, 0),
               wireframe: bool = False, preview: bool = False) -> np.ndarray:
        """Composite ``layers`` over ``background`` and read the result back.

        Parameters
        ----------
        layers : sequence of DrawLayer or str
            Back-to-front stacking list; list order only breaks exact depth ties. A
            DrawLayer is uploaded first (see :meth:`upload`); a str names a layer uploaded
            before, drawn as it is. Keys must be unique within the call.
        canvas : (int, int)
            Canvas (width, height) in the pixels the layer coordinates use.
        size : (int, int), optional
            Output (width, height); the canvas is scaled to it. Default: ``canvas``.
        background : 4 ints 0..255 or ndarray (H, W, 4) uint8
            Straight RGBA colour, or an image stretched over the whole canvas.
        wireframe : bool
            Draw every layer's deformed mesh edges (1 px, dark, semi-opaque) on top.
        preview : bool
            A drag preview, not exact: the opaque pass as always, the soft edges blended
            unsorted (method ``"blend"``), into an RGBA8 composite.

        Returns
        -------
        ndarray, shape (H_out, W_out, 4), uint8
            Straight-alpha RGBA, row 0 = top.
        """
        size = _sizes(canvas, size)
        background = check_background(background)
        with self._current():
            previous = self.ctx.fbo
            draws = self._prepare(layers)
            precise = _precise(background)
            if preview:
                return self._preview(draws, canvas, size, background, wireframe, precise, previous)
            targets = self._targets_for(size, dtype="f2" if precise else "f1")
            method = self._choose()
            for _attempt in range(3):
                method = self._frame(draws, canvas, targets, background, wireframe, method, False)
                out = self._passes.read(targets, precise)
                overflow, used, lost = self._take_counters()
                if method == "kbuffer" and overflow:
                    method = "abuffer"  # exact instead: redraw (rare)
                elif not (method == "abuffer" and lost and self._passes.grow(used)):
                    break
            self._finish(previous)
            return out

    def pin_depth(self, layers: Sequence[DrawLayer | str], canvas: tuple[int, int],
                  ranks: Sequence[float]) -> np.ndarray:
        """Per-pixel depth of the front-most layer: at each pixel centre of the ``canvas``
        (drawn at its own size), the interpolated depth of the front-most triangle whose
        texel under it (nearest) has alpha > 0, less that layer's ``ranks`` entry; NaN
        where no layer shows. Front-most as in :meth:`render` (larger depth; at a tie the
        later triangle, then the later layer). The CPU reference is
        ``tests/room/reference.py`` (``layer_depth``, and ``front_depth`` before its growth).

        Returns
        -------
        ndarray, shape (H, W), float32; row 0 = top.
        """
        w, h = _sizes(canvas, None)
        with self._current():
            previous = self.ctx.fbo
            draws = self._prepare(layers)
            program = load_program(self.ctx, "pindepth")
            live = [(i, mesh, tex) for i, mesh, tex in draws if mesh.counts["opaque"]]
            lo = min((m.lo for _, m, _ in live), default=0.0)
            hi = max((m.hi for _, m, _ in live), default=0.0)
            top, inv = depth_window(lo, hi)
            set_uniform(program, "u_ndc", (2.0 / w, 2.0 / h, -1.0, -1.0))
            set_uniform(program, "u_depth", (top, inv))
            set_uniform(program, "u_texture", 0)
            if self._depth_fbo is None or self._depth_fbo.size != (w, h):  # the last size's kept
                self._drop_depth_fbo()
                self._depth_fbo = self.ctx.framebuffer([self.ctx.texture((w, h), 2, dtype="f4")],
                                                       self.ctx.depth_renderbuffer((w, h)))
                self._depth_fbo.extra = OWN
            fbo = self._depth_fbo
            fbo.use()
            self.ctx.enable_only(moderngl.DEPTH_TEST)
            self.ctx.depth_func = "<="
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            for i, mesh, tex in live:
                set_uniform(program, "u_rank", float(ranks[i]))
                tex.use(0)
                mesh.drawn_array(self.ctx, "pindepth", program).render(moderngl.TRIANGLES)
            out = np.frombuffer(fbo.read(components=2, dtype="f4"), np.float32).reshape(h, w, 2)
            self._finish(previous)
        return np.where(out[..., 1] > 0, out[..., 0], np.float32(np.nan))

    def _preview(self, draws, canvas, size, background, wireframe, straight, previous) -> np.ndarray:
        """:meth:`render` of a drag preview: one frame with the ``blend`` edge pass, RGBA8,
        read back premultiplied and made straight on the CPU where it is translucent
        (cheaper than the full-screen pass when few pixels are)."""
        targets = self._targets_for(size)
        self._frame(draws, canvas, targets, background, wireframe, "blend", False)
        out = self._passes.read(targets, False)
        self._finish(previous)
        return unpremultiply_soft(out) if straight else out

    def draw(self, layers: Sequence[DrawLayer | str], canvas: tuple[int, int], *,
             target: moderngl.Framebuffer | moderngl.Texture,
             background: tuple[int, int, int, int] | np.ndarray = (0, 0, 0, 0),
             wireframe: bool = False, flip_y: bool = False, preview: bool = False) -> None:
        """Composite into ``target`` without reading back (the app's preview path).

        Parameters
        ----------
        layers, canvas, background, wireframe
            As in :meth:`render`.
        target : moderngl.Texture or moderngl.Framebuffer
            An RGBA8 texture (drawn into directly) or a framebuffer (``ctx.screen`` too:
            composited at its size, then copied with a blit). Receives premultiplied RGBA;
            over an opaque background that is the same as straight.
        flip_y : bool
            False: canvas top in row 0 (as :meth:`render`'s array); True: canvas top in
            the last row, the right way up on a window.
        preview : bool
            A drag preview: soft edges blended unsorted (as in :meth:`render`).
        """
        direct = isinstance(target, moderngl.Texture)
        if direct and (target.components != 4 or target.dtype != "f1" or target.samples):
            raise ValueError("a target texture must be RGBA8 (components 4, dtype 'f1')")
        size = _sizes(canvas, tuple(target.size))
        background = check_background(background)
        with self._current():
            if self._pending is not None:
                self._take_counters()  # the previous frame's (done by now, in the app)
            draws = self._prepare(layers)
            targets = self._targets_for(size, target if direct else None)
            previous = self.ctx.fbo
            self._frame(draws, canvas, targets, background, wireframe, "blend" if preview else self._choose(), flip_y)
            if not direct:
                self.ctx.copy_framebuffer(target, targets.write_fbo)
            self._finish(previous)

    def reserve(self, size: tuple[int, int], *,
                background: tuple[int, int, int, int] | np.ndarray = (0, 0, 0, 0), full: bool = False) -> None:
        """Allocate now the render targets that :meth:`render` at ``size`` over
        ``background`` draws into (kept for it, as after a frame), so that a size the
        driver has no memory for is found before anything is drawn, without allocating a
        frame twice. Raises ``moderngl.Error`` when the allocation fails (nothing is kept
        then). ``full``: also those a frame makes on first use (the K-buffer's attachments
        when it would use them, the straight-alpha output of a half-float composite), so
        that a caller can have them made while it does other work (a scene's first frame)."""
        size = _sizes(size, None)
        dtype = "f2" if _precise(check_background(background)) else "f1"
        with self._current():
            self.ctx.error  # noqa: B018 - a stale flag is not this allocation's
            targets = self._targets_for(size, dtype=dtype)
            error = self.ctx.error
            if error != "GL_NO_ERROR":
                self._targets.pop((size, dtype, None), None)
                self._release_targets([targets])
                raise moderngl.Error(f"cannot allocate the {size[0]}x{size[1]} targets: {error}")
            if full:
                self._reserve_rest(targets)

    def _reserve_rest(self, targets: FrameTargets) -> None:
        """The targets a full frame makes on first use, made now (a K-buffer that does not
        fit is left to the frame, which then takes the A-buffer, as it would)."""
        if self._choose() == "kbuffer":
            try:
                targets.kbuffer()
            except moderngl.Error:
                self.ctx.error  # noqa: B018 - the failed allocation's flag (the frame takes the A-buffer)
        if targets.dtype == "f2":
            targets.output()

    def forget_overflow(self) -> None:
        """Start the next frame as a fresh compositor would (``auto``: the K-buffer first,
        the A-buffer on overflow), whatever earlier frames overflowed."""
        self._prefer_abuffer = False

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

    def retain(self, keys) -> int:
        """Forget every cached layer whose key is not in ``keys`` (renamed or removed
        layers, scenes no longer drawn): their textures and buffers would otherwise stay
        for the compositor's life. Returns how many were forgotten."""
        keep = set(keys)
        stale = [k for k in self._textures.keys() | self._meshes.keys() if k not in keep and k != BACKGROUND]
        for k in stale:
            self.invalidate(k)
        return len(stale)

    def release(self) -> None:
        """Release every GL object (and the context when the compositor created it).

        The compositor cannot be used afterwards; a second call does nothing.
        """
        if self._passes is None:
            return
        self.invalidate()
        with self._current():
            self._drop_targets()
            self._drop_depth_fbo()
            self._passes.release()
            self._passes = None
        if self._own_ctx:
            self.ctx.release()

    # -- a frame ------------------------------------------------------------------
    def _current(self):
        """Make an owned context current for a block (several may live in one thread);
        nothing when it already is (``with ctx:`` must not nest)."""
        if not self._own_ctx or is_current(self.ctx):
            return contextlib.nullcontext()
        return self.ctx

    def _choose(self) -> str:
        if self.method != "auto":
            return self.method
        return "abuffer" if (self._prefer_abuffer or not self._fetch) else "kbuffer"

    def _prepare(self, layers) -> list[Draw]:
        """(list position, mesh, texture) of every layer, uploading DrawLayers."""
        keys = [item if isinstance(item, str) else item.key for item in layers]
        if len(set(keys)) != len(keys):
            raise ValueError("layer keys must be unique within one call")
        for item in layers:
            if isinstance(item, str):
                if item not in self._meshes:
                    raise KeyError(f"layer {item!r} is not uploaded")
            else:
                self._upload(item)
        self.ctx.error  # noqa: B018 - clears a GL error left by the caller
        return [(i, self._meshes[k], self._textures[k][1]) for i, k in enumerate(keys)]

    def _upload(self, layer: DrawLayer) -> None:
        mesh = self._meshes.get(layer.key)
        if mesh is not None and mesh.fits(layer):  # a new pose of the same mesh
            deformed, depth = check_vertices(layer.key, len(mesh.posz), layer.deformed,
                                             layer.depth)
        else:
            check_layer(layer)
            self._texture(layer.key, layer.image)
            if mesh is not None:
                mesh.release()
            mesh = self._meshes[layer.key] = LayerMesh(self.ctx, layer, self._passes.programs)
            deformed, depth = layer.deformed, layer.depth
        mesh.write(np.asarray(deformed, np.float64), np.asarray(depth, np.float64))

    def _finish(self, previous) -> None:
        error = self.ctx.error
        if previous is not None and previous.extra is not OWN:
            previous.use()
        if error != "GL_NO_ERROR":
            raise RuntimeError(f"OpenGL error while compositing: {error}")

    def _frame(self, draws: list[Draw], canvas, targets: FrameTargets, background,
               wireframe: bool, method: str, flip: bool) -> str:
        method = self._passes.frame(draws, canvas, targets, background, self._background(background),
                                    method=method, wireframe=wireframe, flip=flip)
        self.last_method = method
        self._pending = None if method == "blend" else method  # a preview's counters are not read
        return method

    def _background(self, background: np.ndarray) -> moderngl.Texture | None:
        """The texture of a background image; None for a colour."""
        return None if background.shape[:2] == (1, 1) else self._texture(BACKGROUND, background)

    def _take_counters(self) -> tuple[int, int, int]:
        """Read the last frame's counters (waits for that frame) and update the hint."""
        overflow, used, lost = self._passes.read_counters()
        self.last_overflow = overflow
        if self._pending == "kbuffer" and overflow:
            self._prefer_abuffer = True
        elif self._pending == "abuffer" and not overflow:
            self._prefer_abuffer = False
        if lost:
            self._passes.grow(used)
        self._pending = None
        return overflow, used, lost

    # -- resources ----------------------------------------------------------------
    def _targets_for(self, size, main: moderngl.Texture | None = None, *,
                     dtype: str = "f1") -> FrameTargets:
        """Targets of this size and format (or around the caller's texture ``main``);
        the last :data:`KEEP_TARGETS` are kept, so render() and draw() alternate freely."""
        key = (size, dtype if main is None else "f1", None if main is None else main.glo)
        targets = self._targets.pop(key, None)
        if targets is not None and main is not None and targets.main is not main:
            self._release_targets([targets])  # a new texture under a recycled name
            targets = None
        if targets is None:
            targets = FrameTargets(self.ctx, size, main, dtype, self._unlocked)
        self._targets[key] = targets  # most recent last
        if len(self._targets) > KEEP_TARGETS:
            old = next(iter(self._targets))
            self._release_targets([self._targets.pop(old)])
        return targets

    def _drop_depth_fbo(self) -> None:
        fbo, self._depth_fbo = self._depth_fbo, None
        if fbo is None:
            return
        if self.ctx.fbo is fbo:  # never leave a deleted framebuffer bound
            self.ctx.detect_framebuffer(0).use()
        for obj in (*fbo.color_attachments, fbo.depth_attachment, fbo):
            obj.release()

    def _drop_targets(self) -> None:
        self._release_targets(list(self._targets.values()))
        self._targets = {}

    def _release_targets(self, targets: list[FrameTargets]) -> None:
        if not targets:
            return
        fbo = self.ctx.fbo
        if fbo is not None and fbo.extra is OWN:
            # never leave a deleted framebuffer bound (GL_INVALID_OPERATION later)
            self.ctx.detect_framebuffer(0).use()
        for t in targets:
            t.release()

    def _texture(self, key: str, image: np.ndarray) -> moderngl.Texture:
        """Cached texture of ``key``; re-uploaded when the array object or shape changes."""
        entry = self._textures.get(key)
        if entry is not None and entry[0] is image and entry[0].shape == image.shape:
            return entry[1]
        if entry is not None:
            entry[1].release()
        h, w = image.shape[:2]
        tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(premultiply(image)))
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = False  # clamp to edge
        self._textures[key] = (image, tex)  # holding the array keeps its id unique
        return tex


def _precise(background: np.ndarray) -> bool:
    """Composite in half floats: the background is an image or not opaque (its colours
    then survive to the straight-alpha output within 1 grey level)."""
    return background.shape[:2] != (1, 1) or int(background[0, 0, 3]) < 255


def _sizes(canvas, size) -> tuple[int, int]:
    cw, ch = (int(v) for v in canvas)
    size = (cw, ch) if size is None else (int(size[0]), int(size[1]))
    if min(cw, ch, *size) <= 0:
        raise ValueError(f"canvas {canvas} and size {size} must be positive")
    return size
