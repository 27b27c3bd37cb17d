"""Export an animation: a folder of PNG frames, a GIF, an H.264 MP4, a VP9 WebM with
alpha, an APNG, a sprite sheet PNG with its JSON atlas, or (drawing nothing: the solved
meshes) a self-contained web player, Spine 4.2 JSON or glTF 2.0 — the table
:data:`puppet.anim.formats.FORMATS`.

Every frame is solved from scratch (trajectory invariance) and streamed to its output
as soon as it is drawn, through the three-stage pipeline of :mod:`puppet.anim.pipeline`
(solve ahead on a thread, composite with GL here, encode on a thread): memory does not
grow with the number of frames. With ``workers`` (``--workers N``), frames are solved in N
processes side by side and encoded on N threads, the output unchanged. All writing goes
through :mod:`puppet.output` (checked before the first frame is drawn, temporary name or
folder, renamed or swapped in at the end, inputs never overwritten, nothing left behind
on an error or a signal).
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator

import numpy as np

from puppet.anim import formats, pipeline, sinks
from puppet.anim.options import MAX_FPS, MIN_FPS, parse_background  # noqa: F401 (docs/api.md names export.parse_background)
from puppet.anim.options import KEY_TOLERANCE, WORKER_BYTES, parse_simplify, parse_tolerance, parse_workers
from puppet.anim.options import worker_cap
from puppet.anim.solver import Drawing, ProcessSolver, SolverPool
from puppet.errors import SceneError
from puppet.output import Staged, check_file, check_folder, commit_all, write_folder
from puppet.scene.format.inputs import input_files
from puppet.scene.time import timeline

#: Most frames one ``animate`` may write (duration x fps); longer exports are refused up front.
MAX_FRAMES = 100_000
#: Frames to solve per solver process started by default (``workers=None``): starting one
#: (a fresh ``python`` that imports puppet and builds the scene) costs about as much as
#: solving 20-40 T-rex frames, so a short export is solved on a thread.
FRAMES_PER_SOLVER = 48

# kept importable from here (older callers)
flatten = sinks.flatten


def output_kind(path: str, kind: str | None = None) -> str:
    """The format's kind (``mp4``, ``html``, ``spine``, ``dir`` ...) of an output path, or
    ``kind`` checked against it (see :func:`puppet.anim.formats.find`)."""
    return formats.find(path, kind).kind


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
        if alpha and not formats.BY_KIND[kind].alpha:
            what = "transparent" if background == "transparent" else "a see-through colour"
            raise SceneError(f"--background: {what} is not possible in an MP4 (H.264 has no alpha); "
                             "use .webm, .apng, .gif, .png or a folder, or give an opaque colour")
    return bg, bool(alpha)


def animate_to(scene, output: str, *, fps=None, start=None, end=None, size=None, wireframe=False,
               progress=False, background=None, threads: bool = True, solver: str = "auto",
               timings: pipeline.Timings | None = None, format: str | None = None, workers: int | None = None,
               say: Callable[[str], None] | None = None, tolerance: float | None = None,
               simplify: float | None = None) -> int:
    """Render the scene's animation to ``output``; returns the number of frames.

    Parameters
    ----------
    scene : puppet.api.Scene
    output : a folder (ending in ``/``) or a file whose ending picks the format in
        :data:`puppet.anim.formats.FORMATS` (``.mp4``, ``.webm``, ``.gif``, ``.apng``,
        ``.png`` sprite sheet + ``.json`` atlas, ``.html`` web player, ``.spine.json``, ``.glb``).
    format : a kind of that table (``"spine"`` lets ``output`` end in ``.json``).
    fps, start, end : frame rate and time range (default: the animation's).
    size : (W, H) of the frames (default: the canvas).
    background : None (the scene's), ``"transparent"`` or an RGBA tuple (see :func:`parse_background`).
    progress : True: a progress bar on stderr; a callable: ``progress(done, total)`` after
        each frame is handed to the output (from the calling thread); False: nothing.
    threads : overlap solve, composite and encode (False: one after the other; same output).
    solver : where frames are solved when ``threads`` and one solver is used: ``"thread"``
        (also ``"auto"``) or ``"process"`` (a child process, see :mod:`puppet.anim.solver`;
        falls back to a thread if its first frame differs). Measured on 1000 T-rex frames
        at 1280x720 the two are as fast (49.5 and 50.2 s), the process using ~10 % more
        CPU: threads by default. ``"thread"`` also keeps ``workers`` to one.
    timings : filled with seconds per stage (see :class:`puppet.anim.pipeline.Timings`).
    workers : solver processes (1..1024; default: one per core, at most one per
        :data:`FRAMES_PER_SOLVER` frames). Frames are independent given the keys: with two
        or more, :class:`puppet.anim.solver.SolverPool` solves them side by side and hands
        them on in order, the output identical to one solver's. At most one per core and
        one per 512 MiB of available memory (as ``puppet batch`` caps its workers; a cut
        is told to ``say``) and one per frame. 1: one solver, as ``solver`` says. PNG, GIF
        and video frames are encoded on as many threads (same bytes).
    say : ``say(line)`` for a note to the user (``workers`` cut to what the machine runs).
    tolerance : web player and Spine only: pixels; keys are kept where interpolating
        between them would replay a frame further than this from puppet's (default
        :data:`puppet.anim.options.KEY_TOLERANCE`, 1 px; 0: a key on every frame, as
        before keys were reduced). See :mod:`puppet.anim.keys`.
    simplify : Spine only: pixels; each layer's mesh made coarser where it still draws
        within this of puppet's over every frame (None: the layers' own meshes). See
        :mod:`puppet.anim.simplify`.

    The output and the files beside it are checked (writable, no input of the scene
    overwritten), the frame count bounded (:data:`MAX_FRAMES`), options the format cannot
    honour refused, and a sprite sheet's size checked before anything is drawn.
    """
    anim = scene.data.animation
    if anim is None:
        raise SceneError("the scene has no animation to export", file=scene.file, path="animation")
    fmt = formats.find(output, format)
    formats.check_options(fmt, size=size, wireframe=wireframe, background=background, tolerance=tolerance,
                          simplify=simplify)
    tolerance = KEY_TOLERANCE if tolerance is None else parse_tolerance(tolerance)
    simplify = None if simplify is None else parse_simplify(simplify)
    inputs = input_files(scene.data)
    (check_folder if fmt.folder else check_file)(output, inputs=inputs)
    for path in fmt.side(output):  # names puppet picks: never through a link
        check_file(path, inputs=inputs, follow=False)
    if workers is not None:
        workers = parse_workers(workers, "animate_to: workers=")
    rate = float(fps or anim.fps)
    if not MIN_FPS <= rate <= MAX_FPS:
        raise SceneError(f"{rate:g} fps is outside {MIN_FPS:g}..{MAX_FPS:g}; give --fps",
                         file=None if fps else scene.file, path=None if fps else "animation.fps")
    t0 = anim.keys[0].time if start is None else float(start)
    t1 = anim.keys[-1].time if end is None else float(end)
    n = frame_count(t0, t1, rate)
    bg, alpha = _background(scene, fmt.kind, output, background)
    job = formats.Job(output=output, size=tuple(size or scene.canvas), fps=rate, start=t0, count=n,
                      alpha=alpha, background=bg, scene=scene, inputs=inputs, tolerance=tolerance,
                      simplify=simplify)
    timings = pipeline.Timings() if timings is None else timings
    scene.built  # noqa: B018  (built here, on this thread: the solver thread only reads it)

    def solve(i: int):
        return scene.layers(time=t0 + i / rate)

    def composite(layers):
        if not fmt.pixels:
            return layers
        return scene.draw_layers(layers, size=size, wireframe=wireframe, background=bg)

    if fmt.prepare is not None:
        fmt.prepare(job, lambda i: composite(solve(i)))
    cached: dict[int, np.ndarray] = job.extra.pop("cached", {})
    todo = [i for i in range(n) if i not in cached]
    remote = bar = None
    n_solvers = solver_count(workers, len(todo), say) if threads and todo and solver != "thread" else 1

    def frames(encode: Callable | None) -> Iterator[np.ndarray]:
        """The frames in order; with ``encode`` (the solver processes draw and encode),
        encoded: the cached ones here by ``encode``."""
        drawn = pipeline.frames(solve, _as_is if encode else composite, todo, threads=threads, timings=timings,
                                remote=remote)
        try:
            for i in range(n):
                yield (encode(cached.pop(i)) if encode else cached.pop(i)) if i in cached else next(drawn)
        finally:
            drawn.close()

    def fill(tmp: str) -> int:
        job.tmp = tmp
        sink = fmt.open(job)
        try:
            there = fmt.pixels and _draw_there(remote, sink, composite, Drawing(size, wireframe, bg, None))
        except BaseException:
            sink.abort()
            raise
        return sinks.stream(sink, frames(sink.encode if there else None), threads=threads, progress=bar,
                            timings=timings, encoders=n_solvers, encoded=there)

    written = [0]
    try:
        if n_solvers > 1 or (threads and todo and solver == "process"):
            remote = _remote(scene, t0, rate, todo[0], n_solvers)
        bar = _Callback(n, progress) if callable(progress) else pipeline.Progress(n, progress)
        if fmt.folder:
            return write_folder(output, fill, inputs=inputs)

        def write(tmp: str) -> None:
            written[0] = fill(tmp)
        try:  # the output and the files its sink staged beside it (side files first)
            main = Staged(output, write, inputs=inputs)
        except BaseException:
            for side in job.staged:
                side.discard()
            raise
        commit_all([*job.staged, main])
        return written[0]
    finally:
        if bar is not None:
            bar.close()
        if remote is not None:
            remote.close()


def solver_count(workers: int | None, frames: int, say: Callable[[str], None] | None = None) -> int:
    """Solver processes for ``frames`` frames when ``workers`` are asked for (None: the
    default), cut to what the machine runs (see :func:`animate_to`)."""
    cap, cores, memory = worker_cap()
    if workers is None:
        return max(1, min(cap, frames // FRAMES_PER_SOLVER))
    if workers > cap and say is not None:
        gib = f", {memory / 2 ** 30:.1f} GiB of memory available" if memory else ""
        say(f"puppet animate: --workers {workers}: starting {cap} solver processes ({cores} cores{gib}; "
            f"one solves on one core and may need up to {WORKER_BYTES / 2 ** 30:.1f} GiB)")
    return max(1, min(workers, cap, frames))


def _as_is(item):
    return item


def _draw_there(remote, sink, composite: Callable, drawing: Drawing) -> bool:
    """Whether the frames are drawn and encoded in the solver processes (a pool, and a
    sink that can encode elsewhere, :meth:`puppet.anim.sinks.Sink.shipper`), checked on
    the pool's first frame drawn here (see :meth:`puppet.anim.solver.SolverPool.draw`)."""
    ship = getattr(sink, "shipper", lambda: None)()
    if not isinstance(remote, SolverPool) or ship is None:
        return False
    return remote.draw(dataclasses.replace(drawing, ship=ship), composite)


def _remote(scene, t0: float, rate: float, first: int, n: int) -> ProcessSolver | SolverPool | None:
    """``n`` solver processes started (checked on frame ``first``), or None when they
    cannot be used (frames are then solved on a thread)."""
    remote = ProcessSolver(scene, t0, rate) if n == 1 else SolverPool(scene, t0, rate, n)
    return remote if remote.start(first) else None


class _Callback:
    """The progress of :func:`animate_to` handed to ``callback(done, total)``."""

    def __init__(self, total: int, callback):
        self.total, self.callback, self.done = total, callback, 0

    def update(self) -> None:
        self.done += 1
        self.callback(self.done, self.total)

    def close(self) -> None:
        pass
