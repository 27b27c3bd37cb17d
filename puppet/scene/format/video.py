"""A compatible extension of scene format v1: a video as the scene's ``source``.

A scene whose ``source`` is a video file (MP4, WebM, MKV, MOV, AVI) or a folder of
numbered pictures is a *video scene*; so is any scene with a top-level ``video`` key
(the way to use a GIF as a clip: a GIF source alone stays a still picture)::

    "source": "walk/",              # or "walk.mp4", "walk.gif"
    "video": {"start": 0, "fps": 12}

``video.start`` (default 0) is the frame on which the layers' pixels and masks, the
pins and the bones are placed (every still-scene check runs on that frame);
``video.fps`` overrides the file's frame rate (a folder has none: 24). The canvas is
the video's size. ``puppet render`` / ``check`` see the start frame as the source
picture; ``puppet video`` re-poses every frame (:mod:`puppet.video`).
"""
from __future__ import annotations

from puppet.scene.format.schema import Ctx, expect_number, expect_object, join


def parse_video(c: Ctx, raw: dict, source: str | None, canvas) -> dict | None:
    """The validated ``video`` settings ``{"start", "fps", "size", "count"}``, or None for a
    still scene. The source is opened and probed here (an unreadable video fails now)."""
    if "video" not in raw and source is None:
        return None
    from puppet.imaging.frames import FrameSource, is_video  # lazy: scenes with a source picture or clip only

    if "video" not in raw and not is_video(source):
        return None
    v = expect_object(c, raw.get("video", {}), "video", optional=("start", "fps"))
    if source is None:
        raise c.fail("video", "a video scene needs a 'source': a video file or a folder of frames")
    start = expect_number(c, v.get("start", 0), join("video", "start"), lo=0, hi=10_000_000, integer=True)
    fps = expect_number(c, v["fps"], join("video", "fps"), lo=0, lo_open=True, hi=240) if "fps" in v else None
    src = FrameSource(source, scene_file=c.file, json_path="source", fps=fps)
    if start >= src.count:
        raise c.fail(join("video", "start"), f"the video has {src.count} frames (0..{src.count - 1}), "
                                             f"no frame {start}")
    if canvas is not None and tuple(canvas) != src.size:
        raise c.fail("canvas", f"a video scene's canvas is the video's size {src.size[0]}x{src.size[1]} "
                               f"(leave 'canvas' out), got {canvas[0]}x{canvas[1]}")
    return {"start": start, "fps": src.fps, "size": src.size, "count": src.count}


def start_frame(data):
    """The start frame of a video scene's source (its template picture): (H, W, 4) uint8."""
    from puppet.imaging.frames import FrameSource  # lazy: video scenes only

    v = data.video
    return FrameSource(data.source, scene_file=data.file, json_path="source", fps=v["fps"]).frame(v["start"])
