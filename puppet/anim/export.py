"""Export an animation: a folder of PNG frames, a GIF or an H.264 MP4.

Every frame is solved from scratch (trajectory invariance) and streamed to its output
as soon as it is drawn: memory does not grow with the number of frames. All writing
goes through :mod:`puppet.output` (checked before the first frame is drawn, temporary
name or folder, renamed or swapped in at the end, inputs never overwritten).
"""
from __future__ import annotations

import math
import os
import sys
from collections.abc import Iterator

import numpy as np

from puppet.errors import SceneError
from puppet.output import atomic_write, check_file, check_folder, write_folder
from puppet.scene.inputs import input_files

KINDS = {".gif": "gif", ".mp4": "mp4"}
#: Most frames one ``animate`` may write (duration x fps); longer exports are refused up front.
MAX_FRAMES = 100_000
#: Frame rates accepted, frames per second.
MIN_FPS, MAX_FPS = 0.01, 240.0
#: Frames drawn first to choose a GIF's palette, and the pixels taken from them.
GIF_SAMPLE_FRAMES, GIF_SAMPLE_PIXELS = 16, 1 << 20
#: Sample frames kept (not drawn twice) while their RGBA bytes stay under this.
GIF_SAMPLE_CACHE = 64 << 20


def output_kind(path: str) -> str:
    """``dir``, ``gif`` or ``mp4`` from the output path (a trailing slash or an existing folder is a folder)."""
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return "dir"
    ext = os.path.splitext(path)[1].lower()
    if ext not in KINDS:
        raise SceneError(f"-o {path!r}: give a folder (ending in /), a .gif or an .mp4 file")
    return KINDS[ext]


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
    return int(math.floor(span + 1e-9)) + 1


def _frames(scene, start: float, fps: float, indices, size, wireframe) -> Iterator[np.ndarray]:
    """Draw frame ``i`` at ``start + i / fps`` for each i in ``indices``, lazily: (H, W, 4) uint8 each."""
    for i in indices:
        yield scene.render(time=start + i / fps, size=size, wireframe=wireframe)


def _progress(frames: Iterator[np.ndarray], n: int, show: bool) -> Iterator[np.ndarray]:
    """Pass frames through, drawing a progress bar on stderr when ``show``."""
    def say(text: str) -> bool:
        try:
            sys.stderr.write(text)
            sys.stderr.flush()
            return True
        except (OSError, ValueError):  # the terminal went away: stop showing progress, go on
            return False

    k = 0
    for k, f in enumerate(frames, 1):
        yield f
        if show:
            done = int(30 * k / n)
            show = say(f"\r[{'#' * done}{'.' * (30 - done)}] {k}/{n} frames")
    if show and k:
        say("\n")


def flatten(rgba: np.ndarray) -> np.ndarray:
    """Composite straight-alpha RGBA over white, for formats without alpha: (h, w, 4) -> (h, w, 3) uint8."""
    a = rgba[..., 3:4].astype(np.float32) / 255.0
    rgb = rgba[..., :3].astype(np.float32) * a + 255.0 * (1.0 - a)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def gif_sample(frames: dict[int, np.ndarray]) -> np.ndarray:
    """Pixels of the sampled frames (strided to at most :data:`GIF_SAMPLE_PIXELS`), flattened: (k, w', 3)."""
    h, w = next(iter(frames.values())).shape[:2]
    s = max(1, math.ceil(math.sqrt(h * w * len(frames) / GIF_SAMPLE_PIXELS)))
    return np.concatenate([flatten(f[::s, ::s]) for f in frames.values()], axis=0)


def write_gif(path: str, frames, fps: float, palette, *, inputs=()) -> int:
    """Stream RGBA frames to a looping GIF with one ``palette`` (see :mod:`puppet.anim.gif`)."""
    from puppet.anim.gif import GifStream, quantize

    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            gif = None
            for rgba in frames:
                if gif is None:
                    gif = GifStream(f, (rgba.shape[1], rgba.shape[0]), palette, fps)
                gif.add(quantize(flatten(rgba), palette))
            gif.close()
            written[0] = gif.frames_added
    written = [0]
    atomic_write(path, write, inputs=inputs)
    return written[0]


def write_mp4(path: str, frames, fps: float, *, inputs=()) -> int:
    """Stream RGBA frames to H.264 (yuv420p, CRF 18) MP4 through PyAV; odd sizes are padded to even."""
    import av
    from fractions import Fraction

    written = [0]

    def write(tmp: str) -> None:
        with av.open(tmp, mode="w", format="mp4") as box:
            st = None
            for rgba in frames:
                h, w = rgba.shape[:2]
                H, W = h + h % 2, w + w % 2
                if st is None:
                    st = box.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
                    st.width, st.height, st.pix_fmt = W, H, "yuv420p"
                    st.options = {"crf": "18", "preset": "medium"}
                rgb = flatten(rgba)
                if (H, W) != (h, w):
                    rgb = np.pad(rgb, ((0, H - h), (0, W - w), (0, 0)), mode="edge")
                for pkt in st.encode(av.VideoFrame.from_ndarray(rgb, format="rgb24")):
                    box.mux(pkt)
                written[0] += 1
            for pkt in st.encode():
                box.mux(pkt)
    atomic_write(path, write, inputs=inputs)
    return written[0]


def write_dir(path: str, frames, *, inputs=()) -> int:
    """Write ``frame_00000.png``, ... into a new folder swapped in at ``path`` (all or nothing)."""
    from PIL import Image

    def fill(tmp: str) -> int:
        n = 0
        for n, f in enumerate(frames, 1):
            Image.fromarray(np.ascontiguousarray(f)).save(os.path.join(tmp, f"frame_{n - 1:05d}.png"), format="PNG")
        return n
    return write_folder(path, fill, inputs=inputs)


def animate_to(scene, output: str, *, fps=None, start=None, end=None, size=None, wireframe=False,
               progress=False) -> int:
    """Render the scene's animation to ``output``; returns the number of frames.

    The output is checked (writable, no input of the scene overwritten) and the frame
    count bounded (:data:`MAX_FRAMES`) before anything is drawn.
    """
    anim = scene.data.animation
    if anim is None:
        raise SceneError("the scene has no animation to export", file=scene.file, path="animation")
    kind = output_kind(output)
    inputs = input_files(scene.data)
    (check_folder if kind == "dir" else check_file)(output, inputs=inputs)
    rate = float(fps or anim.fps)
    if not MIN_FPS <= rate <= MAX_FPS:
        raise SceneError(f"{rate:g} fps is outside {MIN_FPS:g}..{MAX_FPS:g}; give --fps",
                         file=None if fps else scene.file, path=None if fps else "animation.fps")
    t0 = anim.keys[0].time if start is None else float(start)
    t1 = anim.keys[-1].time if end is None else float(end)
    n = frame_count(t0, t1, rate)
    if kind != "gif":
        frames = _progress(_frames(scene, t0, rate, range(n), size, wireframe), n, progress)
        if kind == "dir":
            return write_dir(output, frames, inputs=inputs)
        return write_mp4(output, frames, rate, inputs=inputs)
    from puppet.anim.gif import palette_from_sample

    picks = sorted({int(round(x)) for x in np.linspace(0, n - 1, min(n, GIF_SAMPLE_FRAMES))})
    sample = dict(zip(picks, _frames(scene, t0, rate, picks, size, wireframe)))
    palette = palette_from_sample(gif_sample(sample))
    if sum(f.nbytes for f in sample.values()) > GIF_SAMPLE_CACHE:
        sample.clear()  # too big to keep: those frames are drawn again

    def frames() -> Iterator[np.ndarray]:
        drawn = _frames(scene, t0, rate, (i for i in range(n) if i not in sample), size, wireframe)
        for i in range(n):
            yield sample.pop(i) if i in sample else next(drawn)
    return write_gif(output, _progress(frames(), n, progress), rate, palette, inputs=inputs)
