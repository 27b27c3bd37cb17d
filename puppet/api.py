"""The Python API: ``puppet.load_scene(path) -> Scene``, an editable scene that can draw
itself (``render``), give its meshes (``mesh``) and follow a dragged pin (``drag``)."""
from __future__ import annotations

import dataclasses
import functools
import os
import threading

import numpy as np

from puppet.errors import SceneError
from puppet.scene.document.core import Document, PoseLike
from puppet.scene.drag.session import DragSession, drag_solver, drag_targets
from puppet.scene.format import args as ck
from puppet.scene.rig.build import reduced_rgba
from puppet.scene.rig.cache import fingerprint
from puppet.scene.rig.core import LayerResult

#: Largest preview frame of a drag, pixels (a 4000x4000 picture previews at 640x640, about
#: what a 1280x800 window shows of it; compositing time grows with the pixels drawn).
PREVIEW_PIXELS = 640 * 640
#: Suffix of the compositor keys of a preview's shrunk layer images.
PREVIEW_KEY = "@preview"


def posed_layers(v, a: ck.Arg) -> list[LayerResult]:
    """:meth:`Scene.draw_layers`' layers: one posed :class:`LayerResult` per layer of the scene."""
    n = len(a.owner.data.layers)
    if not isinstance(v, (list, tuple)) or len(v) != n or not all(isinstance(r, LayerResult) for r in v):
        raise a.fail(f"be the scene's {n} posed layers (LayerResults, as layers() gives them)", v)
    return list(v)


class Scene(Document):
    """A loaded, editable scene that can also draw itself.

    It draws with its own compositor (one EGL context, created on first use) unless one
    is given: ``scene.compositor = Compositor(ctx)`` draws into an app's context.
    """

    def __init__(self, doc: dict, file: str):
        super().__init__(doc, file)
        self._compositor = None
        self._own_compositor = False
        self._reduced_rest: dict[str, tuple] = {}  # layer -> (rest, shrunk image, rest scaled to it)
        self._drawable: set[tuple[int, int]] = set()  # frame sizes this machine's GL was found to draw
        self._classes: dict[str, tuple] = {}  # layer -> (image, rest, triangles, their triangle classes)

    @property
    def compositor(self):
        """The compositor this scene draws with (created on first use)."""
        if self._compositor is None:
            from puppet.render.compositor import Compositor  # lazy: moderngl, only once a scene draws

            self._compositor = Compositor()
            self._own_compositor = True
        return self._compositor

    @compositor.setter
    def compositor(self, value) -> None:
        if not all(callable(getattr(value, k, None)) for k in ("render", "retain", "release")):
            raise SceneError(f"compositor must be a puppet.render.compositor.Compositor, got {ck.describe(value)}",
                             file=self.file)
        self._compositor = value
        self._own_compositor = False

    @ck.checked(pose=ck.pose_like, time=ck.optional(ck.TIME), size=ck.optional(ck.size), wireframe=ck.flag)
    def render(self, pose: PoseLike = None, time: float | None = None, *, size: tuple[int, int] | None = None,
               wireframe: bool = False) -> np.ndarray:
        """Draw a pose: a name, an ad-hoc dict of pin targets (same form as a pose in the
        file), or None for the active pose; or a time on the animation.

        Returns
        -------
        (H, W, 4) uint8 RGBA array (straight alpha), H x W = ``size`` or the canvas.
        """
        first = self._first_frame_size(size)
        layers = self.layers(pose, time) if first is None else self._layers_beside_targets(pose, time, first)
        return self.draw_layers(layers, size=size, wireframe=wireframe)

    @ck.checked(layers=posed_layers, size=ck.optional(ck.size), wireframe=ck.flag,
                background=ck.optional(ck.colour_or_image), reduce=ck.integer(1, ck.MAX_SIDE), preview=ck.flag,
                canvas=ck.optional(ck.size))
    def draw_layers(self, layers, *, size=None, wireframe: bool = False, background=None,
                    reduce: int = 1, preview: bool = False, canvas: tuple[int, int] | None = None) -> np.ndarray:
        """Composite already posed layers (:meth:`layers` results) into an RGBA array, over
        ``background`` (an RGBA colour or an (H, W, 4) uint8 image; default: the scene's).
        ``canvas`` (W, H): the frame the layers' ``deformed`` positions are given in, if not
        the scene's canvas (layers moved onto another picture's canvas, or into a box of
        it; drawn at ``size`` or that size).
        ``reduce`` > 1 draws from layer images shrunk that many times (drag previews of
        big pictures: far fewer texels to sample; the frame is not exact). ``preview`` blends
        the soft edges unsorted (a drag preview: one cheap pass, not exact; see
        :meth:`~puppet.render.compositor.Compositor.render`)."""
        draw = self._draw_list(layers, reduce)
        background = self.background() if background is None else background
        frame = tuple(canvas) if canvas is not None else self.canvas
        self._check_drawable(size or frame, background)
        if self._own_compositor:  # layers renamed or removed since: their textures go (a shared one is the caller's)
            names = [L.name for L in self.data.layers]
            self._compositor.retain(names + [n + PREVIEW_KEY for n in names])
        return self.compositor.render(draw, frame, size=size,
                                      background=background,
                                      wireframe=wireframe, preview=preview)

    def _draw_list(self, layers, reduce: int = 1) -> list:
        """The compositor's DrawLayers of the visible ``layers`` (a hidden layer is posed, not drawn)."""
        from puppet.render.layers import DrawLayer  # lazy: drawing only (mesh and check draw nothing)

        shown = [k for k, L in enumerate(self.data.layers) if L.visible]
        images, keys = self.built.images, self.built.image_keys
        draw = [DrawLayer(key=layers[k].name, image=images[k].drawn[0], offset=images[k].drawn[1],
                          rest=layers[k].rest, deformed=layers[k].deformed, triangles=layers[k].triangles,
                          depth=layers[k].depth,
                          classes=self._triangle_classes(layers[k], images[k].drawn, keys[k]) if reduce == 1 else None)
                for k in shown]
        if reduce > 1:
            draw = [self._reduced(L, keys[k], reduce) for L, k in zip(draw, shown)]
        return draw

    @ck.checked(layers=posed_layers, canvas=ck.optional(ck.size))
    def pin_depth(self, layers, *, canvas: tuple[int, int] | None = None) -> np.ndarray:
        """(H, W) float32 over the ``canvas`` (default: the scene's) of already posed
        ``layers``: at each pixel centre, the depth the pins give the front-most visible
        layer whose texture shows there (its interpolated vertex depth less its stacking
        rank, :attr:`LayerResult.order`); NaN where none does
        (:meth:`puppet.render.compositor.Compositor.pin_depth`)."""
        draw = self._draw_list(layers)
        ranks = [layers[k].order for k, L in enumerate(self.data.layers) if L.visible]
        frame = tuple(canvas) if canvas is not None else self.canvas
        self._check_drawable(frame, (0, 0, 0, 0))
        return self.compositor.pin_depth(draw, frame, ranks)

    def _first_frame_size(self, size) -> tuple[int, int] | None:
        """The frame size of a render that can make the compositor and its targets while
        the rig is built (:meth:`_layers_beside_targets`): the first one of a scene drawing
        with its own compositor, the rig not built yet, the size known without building it
        (given, the scene's canvas or its source's size); else None."""
        if self._compositor is not None or self._built is not None:
            return None
        if size is None and self.data.canvas is None and self.data.source is None:
            return None
        try:
            return size or self.canvas
        except SceneError:  # an unreadable source: reported where it was before, by the layers
            return None

    def _layers_beside_targets(self, pose, time, size: tuple[int, int]) -> list[LayerResult]:
        """``self.layers(pose, time)``, computed on a thread (with the layers' texture boxes
        and triangle classes) while this one makes the compositor (its EGL context stays on
        this thread) and allocates every target of a full frame of ``size``: at 4000x4000
        about 0.8 GB that the driver zeroes, beside a rig read from the cache. The same GL
        objects and calls as without it, so the same bits. A failure of the layers is
        raised first, as when they came first."""
        out: dict = {}

        def work():
            try:
                if self._built is None:  # the precomputations only if the pose is not on disk
                    self._built = self.rig.build(self.data, lazy_pre=True)
                out["layers"] = self.layers(pose, time)
                for r, im, key in zip(out["layers"], self.built.images, self.built.image_keys):
                    self._triangle_classes(r, im.drawn, key)  # the textures' boxes and classes too
            except BaseException as e:  # noqa: BLE001 - raised on the calling thread below
                out["error"] = e

        thread = threading.Thread(target=work, name="puppet-first-layers")
        thread.start()
        try:
            self._check_drawable(size, self.background(), full=True)
        except Exception as e:  # noqa: BLE001 - after the layers' own failure, if any
            out["late"] = e
        finally:
            thread.join()
        if "error" in out or "late" in out:
            raise out.get("error", out.get("late"))
        return out["layers"]

    def _check_drawable(self, size: tuple[int, int], background, *, full: bool = False) -> None:
        """Refuse, in one line, a frame size that this machine's OpenGL cannot draw (found
        once per size, by allocating the compositor's own targets for it, which the frame
        then uses; ``full``: all of them, see :meth:`Compositor.reserve`; only with the
        scene's own compositor: a shared one's context is its owner's to check)."""
        size = (int(size[0]), int(size[1]))
        if size in self._drawable:
            return
        comp = self.compositor
        if self._own_compositor:
            from puppet.render.context import output_size_problem  # lazy: moderngl, only once a scene draws

            problem = output_size_problem(comp.ctx, size,
                                          allocate=lambda: comp.reserve(size, background=background, full=full))
            if problem:
                raise SceneError(f"draw: a frame of {size[0]}x{size[1]} pixels cannot be drawn: {problem}",
                                 file=self.file)
        self._drawable.add(size)

    def _triangle_classes(self, r: LayerResult, drawn, image_key: str) -> tuple | None:
        """The compositor's triangle classes of a layer drawn from ``drawn`` (its texture
        and offset), as :func:`~puppet.render.layers.classify_triangles` gives them: kept in
        the rig's cache (and on disk, kind ``"classes"``) under the layer's pixels, offset,
        rest mesh and the classifying code, looked up once per mesh version. None (the
        compositor classifies) when a stored entry does not fit the mesh."""
        from puppet.render.layers import classes_fit, classify_triangles, texture_uv  # lazy: drawing only

        image, offset = drawn
        seen = self._classes.get(r.name)
        if seen is None or seen[0] is not image or seen[1] is not r.rest or seen[2] is not r.triangles:
            key = fingerprint(_classifier_stamp(), image_key, image.shape, offset, r.rest, r.triangles)
            classes = self.rig.memo.get("classes", key, lambda: classify_triangles(
                image, texture_uv(r.rest, offset, image.shape), r.triangles))
            fit = classes_fit(classes, len(r.triangles))
            seen = self._classes[r.name] = (image, r.rest, r.triangles, classes if fit else None)
        return seen[3]

    def _reduced(self, L, image_key: str, reduce: int):
        """``L`` drawn from its image shrunk ``reduce`` times: the rest positions scaled
        about the offset so that every vertex keeps its texture coordinate."""
        image = self.rig.memo.get("reduced", fingerprint(image_key, reduce),
                                  lambda: reduced_rgba(L.image, reduce))
        seen = self._reduced_rest.get(L.key)
        if seen is None or seen[0] is not L.rest or seen[1] is not image:  # the same array each frame:
            (h, w), (sh, sw) = L.image.shape[:2], image.shape[:2]  # the compositor keeps its buffers
            off = np.asarray(L.offset, float)
            seen = (L.rest, image, off + (np.asarray(L.rest, float) - off) * [sw / w, sh / h])
            self._reduced_rest[L.key] = seen
        return dataclasses.replace(L, key=L.key + PREVIEW_KEY, image=image, rest=seen[2], classes=None)

    @ck.checked(names=ck.texts, time=ck.optional(ck.TIME), record=ck.flag, iterations=ck.ITERATIONS,
                size=ck.optional(ck.size), solver=ck.optional(drag_solver))
    def drag(self, names, time: float | None = None, *, record: bool = False, iterations: int = 4,
             size: tuple[int, int] | None = None, solver=None) -> "Drag":
        """Start dragging pins ``names`` (one name or a list) in the active pose, keyed at
        ``time``, or recording from ``time``; previews solved in ``solver`` (a
        :class:`~puppet.scene.drag.process.DragProcess`) when given (see :class:`Drag`)."""
        return Drag(self, names, time, record=record, iterations=iterations, size=size, solver=solver)

    @ck.checked()
    def close(self) -> None:
        """Release the scene's compositor (and its GL context), if it made one."""
        if self._compositor is not None and self._own_compositor:
            self._compositor.release()
        self._compositor, self._own_compositor = None, False


class Drag(DragSession):
    """A :class:`~puppet.scene.drag.session.DragSession` that also draws: :meth:`move` gives a
    preview frame, :meth:`release` the exact one.

    Preview frames are ``size`` (default: the canvas) scaled down to at most
    :data:`PREVIEW_PIXELS` pixels; the released frame is full size.
    """

    @ck.checked("Drag", size=ck.optional(ck.size))
    def __init__(self, scene: Scene, names, time=None, *, record=False, iterations=4, size=None, solver=None):
        super().__init__(scene, names, time, record=record, iterations=iterations, solver=solver)
        self.size = size
        self.preview_size = preview_size(size or scene.canvas)
        self.reduce = max(1, int(scene.canvas[0] / self.preview_size[0]))

    @ck.checked(targets=drag_targets, time=ck.optional(ck.TIME))
    def move(self, targets, time: float | None = None) -> np.ndarray:
        """Move the pins (``(x, y)`` for a one-pin drag, else ``{name: (x, y)}``); returns a
        preview frame (h, w, 4) uint8 of :attr:`preview_size`, drawn from layer images
        shrunk to about that scale when the canvas is two or more times bigger."""
        return self.doc.draw_layers(self.move_layers(targets, time), size=self.preview_size, reduce=self.reduce,
                                     preview=True)

    @ck.checked(keys=ck.optional(ck.timed_tables))
    def release(self, keys=None) -> np.ndarray:
        """End the drag (:meth:`commit`) and return the exact frame: equal to
        ``scene.render(size=size)`` for a pose drag, ``scene.render(time=time, size=size)``
        for a key drag or a recording."""
        return self.doc.draw_layers(self.release_layers(keys), size=self.size)


@functools.lru_cache(maxsize=1)
def _classifier_stamp() -> list:
    """What identifies the code that classifies triangles (a cached entry of kind
    ``"classes"`` is asked for again when it changes): its module's name, size and
    modification time, as the disk cache stamps the modules that build parts."""
    from puppet.render import layers  # lazy: drawing only

    st = os.stat(layers.__file__)
    return ["puppet.render.layers", st.st_size, st.st_mtime_ns]


def preview_size(size: tuple[int, int], pixels: int | None = None) -> tuple[int, int]:
    """``size`` (W, H) scaled down, aspect kept, to at most ``pixels`` pixels (default
    :data:`PREVIEW_PIXELS`)."""
    pixels = PREVIEW_PIXELS if pixels is None else pixels
    w, h = int(size[0]), int(size[1])
    if w * h <= pixels:
        return (w, h)
    f = (pixels / (w * h)) ** 0.5
    return (max(1, int(w * f)), max(1, int(h * f)))


def new_scene(image: str, **options) -> Scene:
    """A new one-layer scene over a picture (see :meth:`Scene.from_image`)."""
    return Scene.from_image(image, **options)


def load_scene(path: str) -> Scene:
    """Read and validate a scene file; raises :class:`puppet.SceneError`."""
    return Scene.load(path)
