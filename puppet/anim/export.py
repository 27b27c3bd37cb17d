"""Export an animation: a folder of PNG frames, a GIF, an H.264 MP4, a VP9 WebM with
alpha, an APNG, or a sprite sheet PNG with its JSON atlas.

Every frame is solved from scratch (trajectory invariance) and streamed to its output
as soon as it is drawn, through the three-stage pipeline of :mod:`puppet.anim.pipeline`
(solve ahead on a thread, composite with GL here, encode on a thread): memory does not
grow with the number of frames. All writing goes through :mod:`puppet.output` (checked
before the first frame is drawn, temporary name or folder, renamed or swapped in at the
end, inputs never overwritten, nothing left behind on an error or a signal).
"""
from __future__ import annotations

import math
import os
from collections.abc import Iterator

import numpy as np

from puppet.anim import pipeline, sinks
from puppet.errors import SceneError
from puppet.output import atomic_write, check_file, check_folder, write_folder
from puppet.scene import timeline
from puppet.scene.inputs import input_files

KINDS = {".gif": "gif", ".mp4": "mp4", ".webm": "webm", ".apng": "apng", ".png": "sheet"}
#: Formats that keep an alpha channel (GIF: one bit).
ALPHA = {"dir", "gif", "webm", "apng", "sheet"}
#: Most frames one ``animate`` may write (duration x fps); longer exports are refused up front.
MAX_FRAMES = 100_000
#: Frame rates accepted, frames per second.
MIN_FPS, MAX_FPS = 0.01, 240.0
#: Frames drawn first to choose a GIF's palette, and the pixels taken from them.
GIF_SAMPLE_FRAMES, GIF_SAMPLE_PIXELS = 16, 1 << 20
#: Sample frames kept (not drawn twice) while their RGBA bytes stay under this.
GIF_SAMPLE_CACHE = 64 << 20

# kept importable from here (older callers)
flatten = sinks.flatten


def output_kind(path: str) -> str:
    """``dir``, ``gif``, ``mp4``, ``webm``, ``apng`` or ``sheet`` (``.png``) from the output
    path (a trailing slash or an existing folder is a folder)."""
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return "dir"
    ext = os.path.splitext(path)[1].lower()
    if ext not in KINDS:
        raise SceneError(f"-o {path!r}: give a folder (ending in /) or a .gif, .mp4, .webm, .apng "
                         "or .png (sprite sheet) file")
    return KINDS[ext]


def atlas_path(path: str) -> str:
    """The JSON atlas beside a sprite sheet: ``OUT.png`` -> ``OUT.json``."""
    return os.path.splitext(path)[0] + ".json"


def parse_background(text: str) -> str | tuple[int, int, int, int]:
    """``transparent``, or a colour: ``#rgb``, ``#rrggbb``, ``#rrggbbaa``, a CSS colour
    name (``white``, ``darkslategray``, ...) or ``rgb(r, g, b)`` -> RGBA 0..255 tuple.

    Raises
    ------
    SceneError
        Anything else (one line naming the flag).
    """
    t = text.strip().lower()
    if t in ("transparent", "none"):
        return "transparent"
    from PIL import ImageColor

    try:
        r, g, b, a = ImageColor.getcolor(t, "RGBA")
    except ValueError:
        raise SceneError(f"{text!r} is not a colour: give transparent, #rrggbb, #rrggbbaa or a colour "
                         "name such as white") from None
    if not all(0 <= v <= 255 for v in (r, g, b, a)):  # Pillow passes rgb(300,0,0), hsl(0,0%,150%) through
        raise SceneError(f"{text!r} is out of range: channels are 0..255 (0..100% for percentages)")
    return int(r), int(g), int(b), int(a)


def frame_count(start: float, end: float, fps: float) -> int:
    """Frames from ``start`` to ``end`` inclusive at ``fps``; refuses more than :data:`MAX_FRAMES`.

    Frame *i* is at ``start + i / fps``; nothing is allocated per frame here.
    """
    if end < start:
        raise SceneError(f"--to {end:g} is before --from {start:g}")
    span = (end - start) * fps
    if not math.isfinite(span) or span + 1 > MAX_FRAMES:
        raise SceneError(f"{end - start:g} s at {fps:g} fps is more than {MAX_FRAMES} frames; "
                         "export it in parts with --from/--to or lower --fps")
    return timeline.frame_count(start, end, fps)


def _background(scene, kind: str, output: str, background) -> tuple[object, bool]:
    """(what the compositor draws over, whether the frames may hold transparency).

    ``background``: None (the scene's), ``"transparent"`` or an RGBA tuple. MP4 has no
    alpha: a see-through colour asked for is refused; a see-through scene background
    is flattened over white.
    """
    if background is None:
        bg = scene.background()
        alpha = np.asarray(bg).reshape(-1, 4)[:, 3].min() < 255
    else:
        bg = (0, 0, 0, 0) if background == "transparent" else tuple(background)
        alpha = bg[3] < 255
        if alpha and kind not in ALPHA:
            what = "transparent" if background == "transparent" else "a see-through colour"
            raise SceneError(f"--background: {what} is not possible in an MP4 (H.264 has no alpha); "
                             "use .webm, .apng, .gif, .png or a folder, or give an opaque colour")
    return bg, bool(alpha)


def _gif_palette(frame_at, n: int, alpha: bool) -> tuple[object, dict[int, np.ndarray]]:
    """A palette from up to :data:`GIF_SAMPLE_FRAMES` frames spread over the animation,
    and those frames (empty when they are too big to keep)."""
    from puppet.anim.gif import palette_from_sample

    picks = sorted({int(round(x)) for x in np.linspace(0, n - 1, min(n, GIF_SAMPLE_FRAMES))})
    sample = {i: frame_at(i) for i in picks}
    h, w = next(iter(sample.values())).shape[:2]
    s = max(1, math.ceil(math.sqrt(h * w * len(sample) / GIF_SAMPLE_PIXELS)))
    if alpha:  # colours of the pixels that show only; index 255 is the see-through one
        px = np.concatenate([f[::s, ::s].reshape(-1, 4) for f in sample.values()])
        px = px[px[:, 3] >= 128, :3]
        palette = palette_from_sample((px if len(px) else np.zeros((1, 3), np.uint8))[None], colors=255)
    else:
        palette = palette_from_sample(np.concatenate([sinks.flatten(f[::s, ::s]) for f in sample.values()]))
    if sum(f.nbytes for f in sample.values()) > GIF_SAMPLE_CACHE:
        sample.clear()  # too big to keep: those frames are drawn again
    return palette, sample


def animate_to(scene, output: str, *, fps=None, start=None, end=None, size=None, wireframe=False,
               progress=False, background=None, threads: bool = True, solver: str = "auto",
               timings: pipeline.Timings | None = None) -> int:
    """Render the scene's animation to ``output``; returns the number of frames.

    Parameters
    ----------
    scene : puppet.api.Scene
    output : a folder (ending in ``/``), or ``.gif``, ``.mp4``, ``.webm``, ``.apng``, ``.png``
        (sprite sheet; its atlas goes to ``.json`` beside it).
    fps, start, end : frame rate and time range (default: the animation's).
    size : (W, H) of the frames (default: the canvas).
    background : None (the scene's), ``"transparent"`` or an RGBA tuple (see :func:`parse_background`).
    progress : draw a progress bar on stderr.
    threads : overlap solve, composite and encode (False: one after the other; same output).
    solver : where frames are solved when ``threads``: ``"thread"`` (also ``"auto"``) or
        ``"process"`` (a child process, see :mod:`puppet.anim.solver`; falls back to a thread
        if its first frame differs). Measured on 1000 T-rex frames at 1280x720 the two are
        as fast (49.5 and 50.2 s), the process using ~10 % more CPU: threads by default.
    timings : filled with seconds per stage (see :class:`puppet.anim.pipeline.Timings`).

    The output is checked (writable, no input of the scene overwritten), the frame count
    bounded (:data:`MAX_FRAMES`) and a sprite sheet's size checked before anything is drawn.
    """
    anim = scene.data.animation
    if anim is None:
        raise SceneError("the scene has no animation to export", file=scene.file, path="animation")
    kind = output_kind(output)
    inputs = input_files(scene.data)
    (check_folder if kind == "dir" else check_file)(output, inputs=inputs)
    if kind == "sheet":
        check_file(atlas_path(output), inputs=inputs)
    rate = float(fps or anim.fps)
    if not MIN_FPS <= rate <= MAX_FPS:
        raise SceneError(f"{rate:g} fps is outside {MIN_FPS:g}..{MAX_FPS:g}; give --fps",
                         file=None if fps else scene.file, path=None if fps else "animation.fps")
    t0 = anim.keys[0].time if start is None else float(start)
    t1 = anim.keys[-1].time if end is None else float(end)
    n = frame_count(t0, t1, rate)
    w, h = size or scene.canvas
    lay = None
    if kind == "sheet":
        from puppet.anim.sheet import MAX_SIDE, layout

        lay = layout(n, w, h)
        if lay is None:
            raise SceneError(f"-o {output!r}: a sprite sheet of {n} frames of {w}x{h} does not fit in "
                             f"{MAX_SIDE}x{MAX_SIDE} pixels; lower --fps, shorten it with --from/--to or "
                             "give a smaller --size")
    bg, alpha = _background(scene, kind, output, background)
    timings = pipeline.Timings() if timings is None else timings
    scene.built  # noqa: B018  (built here, on this thread: the solver thread only reads it)

    def solve(i: int):
        return scene.layers(time=t0 + i / rate)

    def composite(layers) -> np.ndarray:
        return scene.draw_layers(layers, size=size, wireframe=wireframe, background=bg)

    cached: dict[int, np.ndarray] = {}
    palette = None
    if kind == "gif":
        palette, cached = _gif_palette(lambda i: composite(solve(i)), n, alpha)

    todo = [i for i in range(n) if i not in cached]
    remote = bar = None

    def frames() -> Iterator[np.ndarray]:
        drawn = pipeline.frames(solve, composite, todo, threads=threads, timings=timings, remote=remote)
        try:
            for i in range(n):
                yield cached.pop(i) if i in cached else next(drawn)
        finally:
            drawn.close()

    def stream(sink) -> int:
        return sinks.stream(sink, frames(), threads=threads, progress=bar, timings=timings)

    written = [0]
    try:
        if threads and todo and solver == "process":
            from puppet.anim.solver import ProcessSolver

            remote = ProcessSolver(scene, t0, rate)
            if not remote.start(todo[0]):
                remote = None
        bar = pipeline.Progress(n, progress)
        if kind == "dir":
            return write_folder(output, lambda tmp: stream(sinks.DirSink(tmp)), inputs=inputs)

        def write(tmp: str) -> None:
            if kind in ("mp4", "webm", "apng"):
                make = {"mp4": sinks.mp4_sink, "webm": sinks.webm_sink, "apng": sinks.apng_sink}[kind]
                written[0] = stream(make(tmp, (w, h), rate))
                return
            with open(tmp, "wb") as f:
                if kind == "gif":
                    written[0] = stream(sinks.GifSink(f, (w, h), rate, palette, alpha))
                else:
                    written[0] = stream(sinks.SheetSink(f, lay))
                    from puppet.anim.sheet import atlas_text
                    from puppet.output import write_text

                    write_text(atlas_path(output), atlas_text(lay, os.path.basename(output), rate),
                               inputs=inputs)
        atomic_write(output, write, inputs=inputs)
        return written[0]
    finally:
        if bar is not None:
            bar.close()
        if remote is not None:
            remote.close()
