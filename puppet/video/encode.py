"""Stream RGB frames to an MP4 (H.264) or WebM (VP9) file, or a folder of PNG frames,
atomically (:mod:`puppet.output`): nothing is left behind when anything fails.

Encoding runs in a helper thread (PyAV releases the GIL while it encodes), so it
overlaps the work on the next frame; a few frames at most wait in memory (the
export's encoder thread, :func:`puppet.anim.pipeline.run`).
"""
from __future__ import annotations

import os
from collections.abc import Callable, Iterable

import numpy as np

from puppet.anim import sinks
from puppet.errors import SceneError
from puppet.output import atomic_write, write_folder

__all__ = ["output_kind", "write_frames"]

KINDS = {".mp4": "mp4", ".webm": "webm"}
CODECS = {
    "mp4": ("mp4", "libx264", "yuv420p", {"crf": "20", "preset": "veryfast"}),
    "webm": ("webm", "libvpx-vp9", "yuv420p", {"crf": "32", "b": "0", "deadline": "realtime", "cpu-used": "8",
                                             "row-mt": "1"}),
}


def output_kind(path: str) -> str:
    """``dir``, ``mp4`` or ``webm`` from ``-o``: the path's form decides, as for
    ``puppet animate`` (:func:`puppet.anim.formats.find`): a trailing slash, or an existing
    folder without a known ending, is a frame folder; an existing folder at ``out.mp4``
    stays an .mp4 output (refused by the output checker as a folder)."""
    if path.endswith(("/", os.sep)):
        return "dir"
    ext = os.path.splitext(path)[1].lower()
    if ext not in KINDS and os.path.isdir(path):
        return "dir"
    if ext not in KINDS:
        raise SceneError(f"-o {path!r}: give an .mp4 or .webm file, or a folder (ending in /)")
    return KINDS[ext]


def write_frames(path: str, frames: Iterable[np.ndarray], fps: float, kind: str, size: tuple[int, int], *,
                 inputs=(), then: Callable[[int], None] | None = None) -> int:
    """Write (H, W, 3) uint8 RGB frames of ``size`` (W, H) to ``path`` as ``kind`` (``mp4``,
    ``webm``, ``dir``), through the animation export's sinks (:mod:`puppet.anim.sinks`) with
    this tool's codec settings (:data:`CODECS`: faster than the export's, for a stream of
    camera frames).

    Returns the number of frames written. Odd sizes are padded to even for the video codecs.
    ``then(count)``, when given, runs after the last frame is written and before the output
    is put in place: when it raises, nothing is written.
    """
    def finish(count: int) -> int:
        if then is not None:
            then(count)
        return count

    if kind == "dir":
        return write_folder(path, lambda tmp: finish(sinks.stream(sinks.DirSink(tmp), frames)), inputs=inputs)
    fmt, codec, pix, options = CODECS[kind]
    written = [0]

    def write(tmp: str) -> None:
        import av

        try:
            sink = sinks.AVSink(tmp, fmt, codec, pix, size, fps, options, alpha=False, pad=True, threads="AUTO")
            count = sinks.stream(sink, frames)
        except av.FFmpegError as e:  # sizes are checked at the source; this is the codec's last word
            raise SceneError(f"-o {path!r}: the {codec} encoder refuses {size[0]}x{size[1]} frames "
                             f"({' '.join(str(e).split())[:120]})") from None
        written[0] = finish(count)
    atomic_write(path, write, inputs=inputs)
    return written[0]
