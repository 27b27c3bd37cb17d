"""The frames of a video scene, decoded ahead in a background thread.

Decoding (PyAV releases the GIL while it decodes) overlaps the work on the previous
frame; at most :data:`AHEAD` frames wait in memory, so a clip of any length streams.
"""
from __future__ import annotations

import queue
import threading
from collections.abc import Iterator

import numpy as np

from puppet.imaging.frames import FrameSource

__all__ = ["clip_source", "prefetch", "AHEAD"]

#: Frames decoded ahead of the one being worked on.
AHEAD = 4
_END = object()


def clip_source(data) -> FrameSource:
    """The frames of a video scene (``data``: its :class:`~puppet.scene.format.model.SceneData`)."""
    return FrameSource(data.source, scene_file=data.file, json_path="source", fps=data.video["fps"])


def prefetch(src: FrameSource, start: int, stop: int, *, ahead: int = AHEAD,
             partial: bool = False) -> Iterator[tuple[int, np.ndarray]]:
    """``(index, rgba)`` for frames ``start .. stop - 1``, decoded by a helper thread.

    An error in the decoder is raised here, at the frame where it happened (with
    ``partial``, a clip that ends early ends the stream: see :meth:`FrameSource.frames`);
    leaving the loop early stops the thread.
    """
    q: queue.Queue = queue.Queue(maxsize=max(1, ahead))
    stop_flag = threading.Event()

    def put(item) -> bool:
        while not stop_flag.is_set():
            try:
                q.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def work() -> None:
        try:
            for i, f in enumerate(src.frames(start, stop, partial=partial), start):
                if not put((i, f)):
                    return
            put(_END)
        except BaseException as e:  # handed to the consumer
            put(e)

    t = threading.Thread(target=work, name="puppet-video-decode", daemon=True)
    t.start()
    try:
        while True:
            item = q.get()
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop_flag.set()
        t.join(timeout=5)
