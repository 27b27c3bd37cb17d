"""Stream RGB frames to an MP4 (H.264) or WebM (VP9) file, or a folder of PNG frames,
atomically (:mod:`puppet.output`): nothing is left behind when anything fails.

Encoding runs in a helper thread (PyAV releases the GIL while it encodes), so it
overlaps the work on the next frame; a few frames at most wait in memory (the
export's encoder thread, :func:`puppet.anim.pipeline.run`).
"""
from __future__ import annotations

import os
from collections.abc import Iterable

import numpy as np

from puppet.anim import pipeline
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
    """``dir``, ``mp4`` or ``webm`` from ``-o`` (a trailing slash or an existing folder is a folder)."""
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return "dir"
    ext = os.path.splitext(path)[1].lower()
    if ext not in KINDS:
        raise SceneError(f"-o {path!r}: give an .mp4 or .webm file, or a folder (ending in /)")
    return KINDS[ext]


def write_frames(path: str, frames: Iterable[np.ndarray], fps: float, kind: str, *, inputs=()) -> int:
    """Write (H, W, 3) uint8 RGB frames to ``path`` as ``kind`` (``mp4``, ``webm``, ``dir``).

    Returns the number of frames written. Odd sizes are padded to even for the video codecs.
    """
    if kind == "dir":
        return _write_dir(path, frames, inputs=inputs)
    import av
    from fractions import Fraction

    fmt, codec, pix, options = CODECS[kind]
    written = [0]

    def write(tmp: str) -> None:
        with av.open(tmp, mode="w", format=fmt) as box:
            st = None

            def add(rgb: np.ndarray) -> None:
                nonlocal st
                h, w = rgb.shape[:2]
                H, W = h + h % 2, w + w % 2
                if st is None:
                    st = box.add_stream(codec, rate=Fraction(fps).limit_denominator(1000))
                    st.width, st.height, st.pix_fmt = W, H, pix
                    st.options = dict(options)
                    st.thread_type = "AUTO"
                if (H, W) != (h, w):
                    rgb = np.pad(rgb, ((0, H - h), (0, W - w), (0, 0)), mode="edge")
                for pkt in st.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")):
                    box.mux(pkt)
                written[0] += 1

            pipeline.run(frames, add)
            if st is not None:
                for pkt in st.encode():
                    box.mux(pkt)
    atomic_write(path, write, inputs=inputs)
    return written[0]


def _write_dir(path: str, frames: Iterable[np.ndarray], *, inputs=()) -> int:
    from PIL import Image

    def fill(tmp: str) -> int:
        count = [0]

        def save(rgb: np.ndarray) -> None:
            Image.fromarray(rgb).save(os.path.join(tmp, f"frame_{count[0]:05d}.png"), format="PNG", compress_level=1)
            count[0] += 1
        pipeline.run(frames, save)
        return count[0]
    return write_folder(path, fill, inputs=inputs)
