"""Frame sinks: where exported frames go, one format each.

A sink is opened on a temporary path (a file, or a folder for PNG frames) that
:mod:`puppet.output` created, takes straight-alpha RGBA frames one at a time with
:meth:`Sink.add` (from one thread: the export's encoder thread) and finishes the file
with :meth:`Sink.close`. Nothing is kept per frame: memory is flat in the frame count.

===========  ==========================================  ======================
kind         format                                      alpha
===========  ==========================================  ======================
``dir``      ``frame_00000.png``, ... (Up filter, zlib 1)  yes
``gif``      looping GIF, one palette (:mod:`.gif`)       1 bit, when asked
``mp4``      H.264 yuv420p, CRF 18, preset ``veryfast``   no (over the background)
``webm``     VP9 yuva420p (libvpx-vp9), CRF 30            yes (alpha_mode 1)
``apng``     animated PNG (FFmpeg's apng), loops          yes
``sheet``    sprite sheet PNG (:mod:`.sheet`)             yes
===========  ==========================================  ======================

Which path picks which sink is the table :data:`puppet.anim.formats.FORMATS`; the mesh
formats (web player, Spine, glTF) have their sinks in :mod:`.web`, :mod:`.spine`, :mod:`.gltf`.
"""
from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from puppet.anim import pipeline
from puppet.anim.gif import GifStream, palette_from_sample, quantize
from puppet.anim.sheet import SheetWriter, atlas_text, write_png
from puppet.errors import SceneError
from puppet.output import Staged

#: zlib level of PNG frames in a folder, written with the "Up" filter
#: (:func:`puppet.anim.sheet.write_png`): 11 ms of CPU per 1280x720 T-rex frame against
#: 43-48 ms for Pillow (level 1 or its default 6), for a file 1.1x (1.6x) larger.
DIR_LEVEL = 1
#: H.264 options: visually lossless CRF; ``veryfast`` keeps the encoder off the critical path.
MP4_OPTIONS = {"crf": "18", "preset": "veryfast"}
#: VP9 options: constant quality (``b`` 0), speed 4 (``cpu-used``), row threads.
WEBM_OPTIONS = {"crf": "30", "b": "0", "cpu-used": "4", "row-mt": "1", "deadline": "good"}
#: Frames drawn first to choose a GIF's palette, and the pixels taken from them.
GIF_SAMPLE_FRAMES, GIF_SAMPLE_PIXELS = 16, 1 << 20
#: Sample frames kept (not drawn twice) while their RGBA bytes stay under this.
GIF_SAMPLE_CACHE = 64 << 20
#: Most numbers an export that holds every frame until its file is written (Spine, glTF)
#: may take: frames x (vertices x numbers a vertex + layers x the cost of a layer's key,
#: counted in numbers); refused up front above it. Measured (tracemalloc): Spine 17
#: bytes a number (float32 offsets, their JSON text, one layer's text joined), glTF 13
#: (float32 targets, the binary chunk) and ~1.5 kB per layer and frame (its accessor):
#: about 0.7 and 0.5 GB at the limit.
MAX_HELD = 40_000_000


def flatten(rgba: np.ndarray, over=(255, 255, 255)) -> np.ndarray:
    """Composite straight-alpha RGBA over an opaque colour (white by default), for formats
    without alpha: (h, w, 4) -> (h, w, 3) uint8. Opaque frames are only sliced; RGB
    frames (h, w, 3) pass as they are.

    Each pixel is ``rint(c a + over (1 - a))`` in float32 with ``a`` = alpha / 255. That
    is ``c`` where alpha is 255 and ``over`` where it is 0, so only the translucent pixels
    (an animation's edges: a few percent of a frame) are computed; the rest are copied.
    The bytes equal computing every pixel (tested), at a tenth of the time on a 1280x720
    frame (5 ms against 50), which matters when 16 solver processes feed one encoder."""
    if rgba.shape[2] == 3:
        return rgba
    import cv2  # lazy: OpenCV's copies are 10-20x numpy's masked and broadcast ones here

    alpha = cv2.extractChannel(rgba, 3)
    if alpha.min() == 255:
        return rgba[..., :3]
    out = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
    h, w = alpha.shape
    cv2.copyTo(cv2.merge([np.full((h, w), v, np.uint8) for v in over]), (alpha == 0).view(np.uint8), out)
    part = np.flatnonzero((alpha.ravel() - np.uint8(1)) < np.uint8(254))  # 0 < alpha < 255
    if part.size:
        px = rgba.reshape(-1, 4)[part]
        a = px[:, 3:4].astype(np.float32) / 255.0
        rgb = px[:, :3].astype(np.float32) * a + np.asarray(over, np.float32) * (1.0 - a)
        out.reshape(-1, 3)[part] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    return out


def rate(fps: float) -> Fraction:
    """The frame rate as an exact fraction (24 -> 24/1, 29.97 -> 2997/100)."""
    return Fraction(fps).limit_denominator(1001)


def stream(sink: "Sink", frames, encoders: int = 1, encoded: bool = False, **run) -> int:
    """Feed ``frames`` to ``sink`` on the encoder's thread (:func:`puppet.anim.pipeline.run`,
    ``run`` its options) and finish it; on any failure let go of it (the caller removes
    the temporary). The frames written.

    ``encoders`` > 1 (pipelined runs, sinks whose frames encode apart: PNG frames, GIF):
    frames are encoded on that many threads at once (:func:`puppet.anim.pipeline.ahead`)
    and written in order on the encoder's thread; the bytes are the same. ``encoded``:
    the frames are already what :meth:`Sink.write` takes (made by :meth:`Sink.shipper`'s
    function in the solver processes) and are only written."""
    add = sink.write if encoded else sink.add
    if not encoded and encoders > 1 and getattr(sink, "parallel", False) and run.get("threads", True):
        frames, add = pipeline.ahead(frames, sink.encode, encoders, run.get("timings")), sink.write
    try:
        count = pipeline.run(frames, add, **run)
    except BaseException:
        sink.abort()
        raise
    sink.close()
    return count


def check_held(job, per_vertex: int, per_layer: int, what: str) -> None:
    """Refuse, before any frame is solved, an export that would hold more than
    :data:`MAX_HELD` numbers: ``job.count`` frames x (the scene's vertices x
    ``per_vertex`` + its layers x ``per_layer``).

    ``what`` names the format in the message (``"a Spine file"``).

    Raises
    ------
    SceneError
        One line with the frames, the vertices and layers, the product and the limit.
    """
    rest = job.scene.layers(pose="rest")
    vertices = sum(len(r.rest) for r in rest)
    held = job.count * (vertices * per_vertex + len(rest) * per_layer)
    if held > MAX_HELD:
        seconds = (job.count - 1) / job.fps
        raise SceneError(f"-o {job.output!r}: {seconds:g} s at {job.fps:g} fps ({job.count} frames) x {vertices} "
                         f"vertices in {len(rest)} layer{'s' if len(rest) != 1 else ''} would hold {held:.2g} numbers "
                         f"({per_vertex} a vertex and {per_layer} a layer each frame), more than the {MAX_HELD:.2g} "
                         f"that {what} may hold until it is written; export fewer frames (--fps, --from/--to) "
                         "or use .html, which streams")


def stage_bytes(staged: list, path: str, data: bytes, inputs=()) -> None:
    """Write ``data`` in full beside ``path`` (a file whose name puppet picks: an atlas, a
    page image) and append it to ``staged``, to be committed with the output
    (:func:`puppet.output.commit_all`). Never through a link: a symlink at ``path`` is
    refused (``follow=False``), as is an input of the scene or a folder there."""

    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            f.write(data)
    staged.append(Staged(path, write, inputs=inputs, follow=False))


@dataclass(frozen=True)
class PngFile:
    """A frame -> its PNG file (Up filter, zlib ``level``; RGB frames as opaque RGBA)."""

    level: int

    def __call__(self, rgba: np.ndarray) -> bytes:
        if rgba.shape[2] == 3:  # RGB frames (puppet video): opaque RGBA
            rgba = np.concatenate([rgba, np.full(rgba.shape[:2] + (1,), 255, np.uint8)], axis=2)
        buf = io.BytesIO()
        write_png(buf, rgba, self.level)
        return buf.getvalue()


@dataclass(frozen=True)
class GifIndex:
    """A frame -> its palette indices (``transparent``: pixels under half opacity are index 255)."""

    palette: object
    transparent: bool

    def __call__(self, rgba: np.ndarray) -> np.ndarray:
        if self.transparent:
            index = quantize(np.ascontiguousarray(rgba[..., :3]), self.palette)
            return np.where(rgba[..., 3] < 128, np.uint8(255), index)
        return quantize(flatten(rgba), self.palette)


#: Pixel formats PyAV turns into one array and back (``to_ndarray``/``from_ndarray``).
ARRAY_FORMATS = ("yuv420p", "rgba", "rgb24")


@dataclass(frozen=True)
class VideoPixels:
    """A frame -> the video's pixels: flattened over white without ``alpha``, edges
    repeated by ``pad`` (rows, columns), converted to ``pix_fmt``. :meth:`frame` gives the
    ``av.VideoFrame``; called, the array of its planes (the RGB(A) pixels when PyAV
    cannot make one array of ``pix_fmt``), which :meth:`unship` turns into the same frame."""

    alpha: bool
    pad: tuple
    pix_fmt: str

    def pixels(self, rgba: np.ndarray) -> np.ndarray:
        pixels = np.ascontiguousarray(rgba if self.alpha else flatten(rgba))
        if any(self.pad):
            pixels = np.pad(pixels, ((0, self.pad[0]), (0, self.pad[1]), (0, 0)), mode="edge")
        return pixels

    def converted(self, pixels: np.ndarray):
        """The ``av.VideoFrame`` of RGB(A) ``pixels`` in ``pix_fmt``."""
        import av  # lazy: PyAV, only for the video sinks

        frame = av.VideoFrame.from_ndarray(pixels, format="rgba" if self.alpha else "rgb24")
        if frame.format.name == self.pix_fmt:
            return frame
        return frame.reformat(width=frame.width, height=frame.height, format=self.pix_fmt)

    def frame(self, rgba: np.ndarray):
        return self.converted(self.pixels(rgba))

    def __call__(self, rgba: np.ndarray) -> np.ndarray:
        if self.pix_fmt not in ARRAY_FORMATS:
            return self.pixels(rgba)
        return self.frame(rgba).to_ndarray()

    def unship(self, array: np.ndarray):
        """The ``av.VideoFrame`` of what :meth:`__call__` gave."""
        if self.pix_fmt not in ARRAY_FORMATS:
            return self.converted(array)
        import av  # lazy: PyAV, only for the video sinks

        return av.VideoFrame.from_ndarray(array, format=self.pix_fmt)


class Sink:
    """Base of every sink: counts frames.

    A sink whose frames encode apart (``parallel``) splits :meth:`add` into
    :meth:`encode` (no state touched: may run on several threads at once) and
    :meth:`write` (in frame order, one thread)."""

    #: encode() may run for several frames at once
    parallel = False

    def __init__(self) -> None:
        self.frames = 0

    def add(self, rgba: np.ndarray) -> None:
        self.write(self.encode(rgba))

    def encode(self, rgba: np.ndarray):
        """What :meth:`write` takes for a frame (a parallel sink's thread-safe part)."""
        return rgba

    def shipper(self):
        """A picklable function ``rgba -> item`` whose item :meth:`write` takes, for
        another process to encode frames in (:mod:`puppet.anim.solver`), or None
        (this sink encodes here only)."""
        return None

    def write(self, item) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Finish the output (called once, after the last frame)."""

    def abort(self) -> None:
        """Let go of the output after a failure (the caller removes the temporary)."""


class DirSink(Sink):
    """``frame_00000.png``, ``frame_00001.png``, ... in the folder ``tmp``."""

    parallel = True

    def __init__(self, tmp: str, level: int = DIR_LEVEL):
        super().__init__()
        self.tmp, self.level = tmp, level

    def encode(self, rgba: np.ndarray) -> bytes:
        """The frame's PNG file."""
        return self.shipper()(rgba)

    def shipper(self) -> "PngFile":
        return PngFile(self.level)

    def write(self, png: bytes) -> None:
        with open(os.path.join(self.tmp, f"frame_{self.frames:05d}.png"), "wb") as f:
            f.write(png)
        self.frames += 1


def gif_palette(frame_at, n: int, alpha: bool) -> tuple[object, dict[int, np.ndarray]]:
    """A palette from up to :data:`GIF_SAMPLE_FRAMES` frames spread over the animation,
    and those frames (empty when they are too big to keep)."""
    picks = sorted({int(round(x)) for x in np.linspace(0, n - 1, min(n, GIF_SAMPLE_FRAMES))})
    sample = {i: frame_at(i) for i in picks}
    h, w = next(iter(sample.values())).shape[:2]
    s = max(1, math.ceil(math.sqrt(h * w * len(sample) / GIF_SAMPLE_PIXELS)))
    if alpha:  # colours of the pixels that show only; index 255 is the see-through one
        px = np.concatenate([f[::s, ::s].reshape(-1, 4) for f in sample.values()])
        px = px[px[:, 3] >= 128, :3]
        palette = palette_from_sample((px if len(px) else np.zeros((1, 3), np.uint8))[None], colors=255)
    else:
        palette = palette_from_sample(np.concatenate([flatten(f[::s, ::s]) for f in sample.values()]))
    if sum(f.nbytes for f in sample.values()) > GIF_SAMPLE_CACHE:
        sample.clear()  # too big to keep: those frames are drawn again
    return palette, sample


class GifSink(Sink):
    """A looping GIF through :class:`puppet.anim.gif.GifStream`; with ``transparent``,
    pixels under half opacity are see-through and the palette has 255 colours."""

    parallel = True

    def __init__(self, fp, size: tuple[int, int], fps: float, palette, transparent: bool):
        super().__init__()
        self.palette, self.transparent = palette, transparent
        self.stream = GifStream(fp, size, palette, fps, transparent=255 if transparent else None)

    def encode(self, rgba: np.ndarray) -> np.ndarray:
        """The frame's palette indices."""
        return self.shipper()(rgba)

    def shipper(self) -> "GifIndex":
        return GifIndex(self.palette, self.transparent)

    def write(self, index: np.ndarray) -> None:
        self.stream.add(index)
        self.frames += 1

    def close(self) -> None:
        self.stream.close()


class AVSink(Sink):
    """A video through PyAV: ``codec`` into ``container``, frames given as RGBA (or RGB
    when ``alpha`` is False) and converted by FFmpeg to ``pix_fmt``; ``pad`` makes odd
    sizes even (edge pixels); ``threads`` is the codec's thread type (e.g. ``"AUTO"``:
    frame and slice threads), FFmpeg's default when None. The conversion
    (:meth:`encode`) may run for several frames at once; the codec takes them in order
    (:meth:`write`)."""

    parallel = True

    def __init__(self, tmp: str, container: str, codec: str, pix_fmt: str, size: tuple[int, int],
                 fps: float, options: dict[str, str], *, alpha: bool, pad: bool = False,
                 container_options: dict[str, str] | None = None, threads: str | None = None):
        import av

        super().__init__()
        w, h = size
        self.pad = (h % 2, w % 2) if pad else (0, 0)
        self.alpha, self.pix_fmt = alpha, pix_fmt
        self.box = av.open(tmp, mode="w", format=container, options=container_options or {})
        try:
            self.stream = self.box.add_stream(codec, rate=rate(fps))
            self.stream.width, self.stream.height = w + self.pad[1], h + self.pad[0]
            self.stream.pix_fmt = pix_fmt
            self.stream.options = dict(options)
            if threads is not None:
                self.stream.thread_type = threads
        except BaseException:
            self.box.close()
            raise

    def encode(self, rgba: np.ndarray):
        """The frame as the codec takes it (``av.VideoFrame`` in the stream's pixel format):
        the conversion FFmpeg would make inside the encoder, here where several frames
        can be converted at once (the same pixels: tested against PyAV converting)."""
        return self.shipper().frame(rgba)

    def shipper(self) -> "VideoPixels":
        return VideoPixels(self.alpha, self.pad, self.pix_fmt)

    def write(self, frame) -> None:
        """Encode ``frame``: an ``av.VideoFrame`` (:meth:`encode`) or the array a
        :class:`VideoPixels` made (in a solver process)."""
        if isinstance(frame, np.ndarray):
            frame = self.shipper().unship(frame)
        frame.pts = self.frames
        for pkt in self.stream.encode(frame):
            self.box.mux(pkt)
        self.frames += 1

    def close(self) -> None:
        try:
            for pkt in self.stream.encode():
                self.box.mux(pkt)
        finally:
            self.box.close()

    def abort(self) -> None:
        try:
            self.box.close()
        except Exception:  # the container is half written and will be removed anyway
            pass


def mp4_sink(tmp: str, size, fps: float) -> AVSink:
    return AVSink(tmp, "mp4", "libx264", "yuv420p", size, fps, MP4_OPTIONS, alpha=False, pad=True, threads="AUTO")


def webm_sink(tmp: str, size, fps: float) -> AVSink:
    return AVSink(tmp, "webm", "libvpx-vp9", "yuva420p", size, fps, WEBM_OPTIONS, alpha=True)  # VP9: odd sizes fine


def apng_sink(tmp: str, size, fps: float) -> AVSink:
    """FFmpeg's APNG muxer writes each frame's delay as the exact fraction 1/fps; ``plays`` 0 loops."""
    return AVSink(tmp, "apng", "apng", "rgba", size, fps, {}, alpha=True, container_options={"plays": "0"})


class SheetSink(Sink):
    """A sprite sheet PNG (see :mod:`puppet.anim.sheet`); with ``atlas`` = (atlas path,
    sheet path, fps, inputs) its JSON atlas is written when the sheet is done: staged
    into ``staged`` (committed with the sheet by the export), or, without it, put in
    place at once; never through a link."""

    def __init__(self, fp, lay, atlas: tuple | None = None, staged: list | None = None):
        super().__init__()
        self.writer, self.lay, self.atlas, self.staged = SheetWriter(fp, lay), lay, atlas, staged

    def add(self, rgba: np.ndarray) -> None:
        self.writer.add(rgba)
        self.frames += 1

    def close(self) -> None:
        self.writer.close()
        if self.atlas is not None:
            path, sheet, fps, inputs = self.atlas
            staged = [] if self.staged is None else self.staged
            stage_bytes(staged, path, atlas_text(self.lay, os.path.basename(sheet), fps).encode("utf-8"), inputs)
            if self.staged is None:
                staged[0].commit()
