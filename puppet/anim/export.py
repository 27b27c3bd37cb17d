"""Export an animation: a folder of PNG frames, a GIF or an H.264 MP4.

Every frame is solved from scratch (trajectory invariance). Outputs are written to a
temporary name and renamed at the end, so a failure leaves nothing behind.
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import atomic_write
from puppet.scene.timeline import frame_times

KINDS = {".gif": "gif", ".mp4": "mp4"}


def output_kind(path: str) -> str:
    """``dir``, ``gif`` or ``mp4`` from the output path (a trailing slash or an existing folder is a folder)."""
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return "dir"
    ext = os.path.splitext(path)[1].lower()
    if ext not in KINDS:
        raise SceneError(f"-o {path!r}: give a folder (ending in /), a .gif or an .mp4 file")
    return KINDS[ext]


def _frames(scene, times, size, wireframe, progress):
    n = len(times)
    for i, t in enumerate(times):
        yield scene.render(time=float(t), size=size, wireframe=wireframe)
        if progress:
            done = int(30 * (i + 1) / n)
            sys.stderr.write(f"\r[{'#' * done}{'.' * (30 - done)}] {i + 1}/{n} frames")
            sys.stderr.flush()
    if progress:
        sys.stderr.write("\n")


def flatten(rgba: np.ndarray) -> np.ndarray:
    """Composite straight-alpha RGBA over white, for formats without alpha."""
    a = rgba[..., 3:4].astype(np.float32) / 255.0
    rgb = rgba[..., :3].astype(np.float32) * a + 255.0 * (1.0 - a)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def write_gif(path: str, frames: list[np.ndarray], fps: float) -> None:
    """GIF with one palette shared by all frames (adaptive, from a sample of frames)."""
    from PIL import Image

    rgb = [flatten(f) for f in frames]
    step = max(1, len(rgb) // 8)
    sample = np.concatenate(rgb[::step], axis=0)
    pal = Image.fromarray(sample).quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    ims = [Image.fromarray(f).quantize(palette=pal, dither=Image.Dither.NONE) for f in rgb]
    ms = max(10, int(round(100.0 / fps)) * 10)  # GIF stores 10 ms steps
    atomic_write(path, lambda tmp: ims[0].save(tmp, format="GIF", save_all=True, append_images=ims[1:],
                                               duration=ms, loop=0, disposal=1))


def write_mp4(path: str, frames: list[np.ndarray], fps: float) -> None:
    """H.264 (yuv420p) MP4 through PyAV; odd sizes are padded to even."""
    import av
    from fractions import Fraction

    h, w = frames[0].shape[:2]
    H, W = h + h % 2, w + w % 2

    def write(tmp):
        with av.open(tmp, mode="w", format="mp4") as box:
            st = box.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
            st.width, st.height, st.pix_fmt = W, H, "yuv420p"
            st.options = {"crf": "18", "preset": "medium"}
            for f in frames:
                rgb = flatten(f)
                if (H, W) != (h, w):
                    rgb = np.pad(rgb, ((0, H - h), (0, W - w), (0, 0)), mode="edge")
                for pkt in st.encode(av.VideoFrame.from_ndarray(rgb, format="rgb24")):
                    box.mux(pkt)
            for pkt in st.encode():
                box.mux(pkt)
    atomic_write(path, write)


def write_dir(path: str, frames) -> int:
    """Write ``frame_00000.png``, ... into ``path`` (created), all or nothing."""
    from puppet.imaging.io import save_png

    target = os.path.abspath(path.rstrip("/" + os.sep))
    parent = os.path.dirname(target)
    if not os.path.isdir(parent):
        raise SceneError(f"-o {path!r}: folder {parent!r} does not exist")
    tmp = tempfile.mkdtemp(prefix=".frames.", dir=parent)
    try:
        n = 0
        for n, f in enumerate(frames, 1):
            save_png(os.path.join(tmp, f"frame_{n - 1:05d}.png"), f)
        if not os.path.exists(target):
            os.replace(tmp, target)
        else:
            for name in sorted(os.listdir(tmp)):
                os.replace(os.path.join(tmp, name), os.path.join(target, name))
            os.rmdir(tmp)
        return n
    finally:
        if os.path.isdir(tmp):
            shutil.rmtree(tmp)


def animate_to(scene, output: str, *, fps=None, start=None, end=None, size=None, wireframe=False,
               progress=False) -> int:
    """Render the scene's animation to ``output``; returns the number of frames."""
    anim = scene.data.animation
    if anim is None:
        raise SceneError("the scene has no animation to export", file=scene.file, path="animation")
    kind = output_kind(output)
    if kind != "dir":
        folder = os.path.dirname(os.path.abspath(output))
        if not os.path.isdir(folder):
            raise SceneError(f"-o {output!r}: folder {folder!r} does not exist")
    t0 = anim.keys[0].time if start is None else start
    t1 = anim.keys[-1].time if end is None else end
    if t1 < t0:
        raise SceneError(f"--to {t1:g} is before --from {t0:g}")
    times = frame_times(anim, fps=fps, start=t0, end=t1)
    rate = fps or anim.fps
    frames = _frames(scene, times, size, wireframe, progress)
    if kind == "dir":
        return write_dir(output, frames)
    frames = list(frames)
    (write_gif if kind == "gif" else write_mp4)(output, frames, rate)
    return len(frames)
