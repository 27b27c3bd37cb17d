"""Frames of a video scene's source: a video file (MP4, WebM, GIF, ...) or a folder of
numbered pictures, streamed one frame at a time (never all in memory).

Videos are decoded with PyAV (imported lazily); a folder's pictures go through
:func:`puppet.imaging.io.load_rgba` (same limits and errors as every image). Every
frame comes out as (H, W, 4) uint8 straight RGBA (alpha 255 for formats without it).
Problems a user can cause (missing, unreadable or empty video, a folder without
pictures, frames of different sizes) raise :class:`~puppet.errors.ImageError` naming
the file, with the scene file and JSON path when given.
"""
from __future__ import annotations

import os
import re
from collections.abc import Iterator

import numpy as np

from puppet.errors import ImageError
from puppet.imaging import io as image_io  # the limits, read when used

#: File name endings read as videos (a GIF is a video only in a video scene: see :func:`is_video`).
VIDEO_EXTS = (".mp4", ".webm", ".mkv", ".mov", ".avi", ".m4v", ".gif")
#: Picture endings taken from a folder of frames.
FRAME_EXTS = (".png", ".jpg", ".jpeg", ".bmp", ".webp", ".tif", ".tiff")
#: Frame rate of a folder of frames (and of a video that does not say), frames per second.
DEFAULT_FPS = 24.0
_NUM = re.compile(r"(\d+)")


def is_video(path: str, *, gif: bool = False) -> bool:
    """Is ``path`` a video source: a folder, or a file with a video ending (a ``.gif``
    only with ``gif=True``, since a GIF is a plain picture in a still scene)?"""
    if os.path.isdir(path):
        return True
    ext = os.path.splitext(path)[1].lower()
    return ext in VIDEO_EXTS and (gif or ext != ".gif")


def _natural(name: str):
    return [int(t) if t.isdigit() else t.lower() for t in _NUM.split(name)]


class FrameSource:
    """A video or a folder of frames, opened and probed (size, frame rate, frame count).

    Parameters
    ----------
    path : the video file or folder.
    scene_file, json_path : where it was named, for error messages.
    fps : frame rate to use instead of the file's (a folder has none: :data:`DEFAULT_FPS`).

    Attributes
    ----------
    size : (W, H) of every frame. fps : float. count : number of frames (>= 1).
    """

    def __init__(self, path: str, *, scene_file: str | None = None, json_path: str | None = None,
                 fps: float | None = None):
        self.path = path
        self._where = dict(file=scene_file, path=json_path)
        self.folder = os.path.isdir(path)
        self.files: list[str] = []
        if self.folder:
            self._probe_folder()
        else:
            self._probe_video()
        if fps is not None:
            self.fps = float(fps)

    # -- errors ---------------------------------------------------------------------------
    def fail(self, msg: str, what: str | None = None) -> ImageError:
        kind = "frames folder" if self.folder else "video"
        return ImageError(f"{kind} {what or self.path!r}: {msg}", **self._where)

    # -- probing --------------------------------------------------------------------------
    def _probe_folder(self) -> None:
        try:
            names = os.listdir(self.path)
        except OSError as e:
            raise self.fail(f"cannot be read ({e.strerror})") from None
        names = sorted((n for n in names if os.path.splitext(n)[1].lower() in FRAME_EXTS
                        and not n.startswith(".")), key=_natural)
        if not names:
            raise self.fail(f"holds no pictures ({', '.join(FRAME_EXTS)})")
        self.files = [os.path.join(self.path, n) for n in names]
        first = self._load(0)
        self.size = (first.shape[1], first.shape[0])
        self.fps = DEFAULT_FPS
        self.count = len(self.files)

    def _open(self):
        import av

        if not os.path.exists(self.path):
            raise self.fail("no such file")
        if not os.path.isfile(self.path):
            raise self.fail("is not a regular file")
        try:
            box = av.open(self.path, mode="r")
        except (av.FFmpegError, OSError, ValueError) as e:
            raise self.fail(f"cannot be read as a video ({_reason(e)})") from None
        if not box.streams.video:
            box.close()
            raise self.fail("has no video stream")
        st = box.streams.video[0]
        st.thread_type = "AUTO"
        return box, st

    def _probe_video(self) -> None:
        import av

        box, st = self._open()
        try:
            w, h = st.codec_context.width, st.codec_context.height
            rate = st.average_rate or st.guessed_rate or st.base_rate
            self.fps = float(rate) if rate and 0 < float(rate) <= 1000 else DEFAULT_FPS
            n = int(st.frames or 0)
            if n <= 0:  # the container does not say: count packets (no decoding)
                n = sum(1 for p in box.demux(st) if p.size)
        except (av.FFmpegError, OSError, ValueError) as e:
            raise self.fail(f"cannot be read as a video ({_reason(e)})") from None
        finally:
            box.close()
        if w < 1 or h < 1 or n < 1:
            raise self.fail("holds no frames")
        self._check_size(int(w), int(h))
        self.size, self.count = (int(w), int(h)), n

    def _check_size(self, w: int, h: int) -> None:
        """Frames are held to the limits of every image (:data:`~puppet.imaging.io.MAX_SIDE`,
        :data:`~puppet.imaging.io.MAX_PIXELS`), checked before a pixel is decoded."""
        side, pixels = image_io.MAX_SIDE, image_io.MAX_PIXELS
        if w > side or h > side or w * h > pixels:
            raise self.fail(f"frames too large ({w}x{h}; at most {side} per side and {pixels} pixels)")

    # -- reading --------------------------------------------------------------------------
    def _load(self, i: int) -> np.ndarray:
        rgba = image_io.load_rgba(self.files[i], scene_file=self._where["file"], json_path=self._where["path"])
        if i and (rgba.shape[1], rgba.shape[0]) != self.size:
            raise self.fail(f"is {rgba.shape[1]}x{rgba.shape[0]}, the first frame "
                            f"{self.size[0]}x{self.size[1]}", what=repr(self.files[i]))
        return rgba

    def frames(self, start: int = 0, stop: int | None = None, *, partial: bool = False) -> Iterator[np.ndarray]:
        """Frames ``start, start + 1, ... stop - 1`` (to the end when ``stop`` is None),
        decoded one at a time: (H, W, 4) uint8 each. A video is decoded from its beginning
        (frame-exact); frames before ``start`` are decoded and dropped.

        A video that ends before ``stop`` (truncated: fewer frames than its header declares)
        or cannot be decoded from some frame on raises ImageError; with ``partial=True`` the
        frames decoded up to there are the whole stream instead (``self.ended`` then says
        ``(first frame missing, reason)``), unless not one frame was yielded.
        """
        stop = self.count if stop is None else stop
        self.ended = None
        if self.folder:
            for i in range(start, min(stop, self.count)):
                yield self._load(i)
            return
        import av

        box, st = self._open()
        i, reason = 0, ""
        try:
            for frame in box.decode(st):
                if i >= stop:
                    break
                if i >= start:
                    self._check_size(frame.width, frame.height)
                    yield self._rgba(frame)
                i += 1
        except (av.FFmpegError, OSError, ValueError) as e:
            reason = _reason(e)
            if not partial or i <= start:
                raise self.fail(f"cannot be decoded at frame {i} ({reason})") from None
        finally:
            box.close()
        if i < min(stop, self.count):
            if not partial or i <= start:
                raise self.fail(f"ends at frame {i} although it declares {self.count} frames "
                                f"(truncated{': ' + reason if reason else ''})")
            self.ended = (i, reason or "truncated")

    def _rgba(self, frame) -> np.ndarray:
        rgba = frame.to_ndarray(format="rgba")
        if (rgba.shape[1], rgba.shape[0]) != self.size:
            raise self.fail(f"changes size to {rgba.shape[1]}x{rgba.shape[0]} in the middle")
        return rgba

    def frame(self, n: int) -> np.ndarray:
        """Frame ``n`` (0-based): (H, W, 4) uint8."""
        if not 0 <= n < self.count:
            raise self.fail(f"has no frame {n} (it has {self.count})")
        for f in self.frames(n, n + 1):
            return f
        raise self.fail(f"has no frame {n} (it ends before)")


def _reason(e: BaseException) -> str:
    text = getattr(e, "strerror", None) or str(e) or type(e).__name__
    return " ".join(str(text).split())[:120]
