"""Re-pose a character through a clip (Shen et al. 2010, §4): per frame, segment, track the
skeleton, rebuild the target skeleton in relative form, warp with the skeleton MLS and
composite over the refilled background.

:func:`plan_video` checks everything a user can get wrong before the first frame is
decoded (not a video scene, unknown pose, frame range, anchors); :func:`run_video`
streams the re-posed frames. Joint positions outside this module are canvas
coordinates like the scene's pins; the tracker and the warp work in OpenCV pixel
coordinates (canvas minus 0.5).
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from puppet.errors import SceneError
from puppet.scene.format.reader import MAX_SCENE_BYTES, parse_text, read_file
from puppet.scene.format.schema import Ctx, expect_object, expect_point, join
from puppet.video import track
from puppet.video.plate import Plate
from puppet.video.retarget import RelativeSkeleton, relative_skeleton
from puppet.video.segment import Segmenter
from puppet.video.source import clip_source, prefetch
from puppet.video.warp import background_fill, composite, skeleton_maps

__all__ = ["VideoPlan", "FrameResult", "plan_video", "run_video", "read_anchors"]

#: Canvas coordinates minus this are OpenCV pixel coordinates.
HALF = 0.5


@dataclass
class VideoPlan:
    """What one ``puppet video`` run does, validated.

    Attributes
    ----------
    data : the scene's SceneData. layer : the character's Layer.
    names : pin names (the joints). P, T : (k, 2) rest and pose positions (canvas).
    bones : (m, 2) int. rel : the target skeleton in relative form.
    start : the scene's start frame (pins placed there). first, last : output frames (inclusive).
    anchors : frame -> {pin: (x, y)} (canvas). fps : float. size : (W, H). inpaint : method.
    """

    data: object
    layer: object
    names: list[str]
    P: np.ndarray
    T: np.ndarray
    bones: np.ndarray
    rel: RelativeSkeleton
    start: int
    first: int
    last: int
    anchors: dict[int, dict[str, tuple[float, float]]] = field(default_factory=dict)
    fps: float = 24.0
    size: tuple[int, int] = (0, 0)
    inpaint: str = "telea"
    #: Set by :func:`run_video` when the clip ended early: (first frame missing, reason).
    ended: tuple[int, str] | None = None

    @property
    def count(self) -> int:
        """Frames written."""
        return self.last - self.first + 1


@dataclass
class FrameResult:
    """One output frame: ``rgb`` (H, W, 3) uint8, the tracked ``joints`` (k, 2) canvas
    coordinates, their ``confidence`` (k,), whether tracking was ``lost`` (skeleton held) and why."""

    index: int
    rgb: np.ndarray
    joints: np.ndarray
    confidence: np.ndarray
    lost: bool = False
    reason: str = ""


def plan_video(doc, pose: str, *, first: int | None = None, last: int | None = None,
               anchors: dict | None = None) -> VideoPlan:
    """Check a video scene and the run's options; raises SceneError (one line) on bad input."""
    data = doc.data
    if data.video is None:
        raise SceneError("not a video scene: its 'source' must be a video file or a folder of frames "
                         "(or add a 'video' object)", file=data.file, path="source" if data.source else None)
    if pose not in data.poses:
        known = ", ".join(sorted(data.poses)) or "none"
        raise SceneError(f"--pose {pose!r}: no such pose (the scene has: {known})", file=data.file)
    if len(data.layers) != 1 or data.layers[0].image is not None:
        raise SceneError("a video scene has exactly one layer, taking its pixels from the video (the character)",
                         file=data.file, path="layers")
    layer = data.layers[0]
    pins = [p for p in data.pins if p.kind == "interior"]
    if not pins:
        raise SceneError("a video scene needs pins (the joints of the skeleton)", file=data.file, path="pins")
    names = [p.name for p in pins]
    index = {n: i for i, n in enumerate(names)}
    P = np.array([p.at for p in pins], np.float64)
    T = P.copy()
    for n, tgt in data.poses[pose].items():
        if n in index and tgt.to is not None:
            T[index[n]] = tgt.to
    bones = np.array([(index[a], index[b]) for a, b in data.bones if a in index and b in index],
                     np.int64).reshape(-1, 2)
    try:
        rel = relative_skeleton(P, T, bones)
    except ValueError as e:
        raise SceneError(f"bones: {e}", file=data.file, path="bones") from None
    v = data.video
    S, n = v["start"], v["count"]
    a = S if first is None else int(first)
    b = n - 1 if last is None else int(last)
    if not S <= a < n:
        raise SceneError(f"--from {a}: must be a frame from the scene's start frame {S} to {n - 1} "
                         "(the skeleton is placed on the start frame and tracked forward)")
    if not a <= b < n:
        raise SceneError(f"--to {b}: must be a frame from {a} (--from) to {n - 1} (the clip's last)")
    anchors = dict(anchors or {})
    for f, joints in anchors.items():
        if not S < f < n:
            raise SceneError(f"--anchors: frame {f} is not after the start frame {S} and within the clip (0..{n - 1})")
        for name in joints:
            if name not in index:
                raise SceneError(f"--anchors: frame {f}: no pin named {name!r}")
    method = layer.inpaint if layer.inpaint != "none" else "telea"
    return VideoPlan(data=data, layer=layer, names=names, P=P, T=T, bones=bones, rel=rel, start=S,
                     first=a, last=b, anchors=anchors, fps=v["fps"], size=tuple(v["size"]), inpaint=method)


def read_anchors(path: str) -> dict[int, dict[str, tuple[float, float]]]:
    """``{"frame": {"pin": [x, y]}}`` from a JSON file (canvas coordinates); SceneError naming
    the file and the JSON path when it is not that."""
    raw = parse_text(read_file(path, what="--anchors file", max_bytes=MAX_SCENE_BYTES), path)
    c = Ctx(path)
    expect_object(c, raw, "", optional=raw.keys() if isinstance(raw, dict) else ())
    out = {}
    for key, joints in raw.items():
        if not (key.isascii() and key.isdigit() and len(key) <= 9):  # not "²", not 5000 digits
            raise c.fail(join("", key), "expected a frame number (0, 1, ...) as the key")
        expect_object(c, joints, join("", key), optional=joints.keys() if isinstance(joints, dict) else ())
        out[int(key)] = {n: expect_point(c, xy, join(join("", key), n)) for n, xy in joints.items()}
    return out


def run_video(plan: VideoPlan, *, tracker: Callable | None = None, step: int = 6, out_step: int = 4,
              plate: bool = True, timer: dict | None = None) -> Iterator[FrameResult]:
    """Re-posed frames ``plan.first .. plan.last``, streamed.

    Frames from the start frame to ``first - 1`` are tracked but not warped. A clip that
    ends before ``last`` (truncated, or undecodable from some frame on) ends the stream
    there and sets ``plan.ended``; one that yields no frame at all raises ImageError.

    Parameters
    ----------
    tracker : ``Tracker``-like class (default :class:`puppet.video.track.Tracker`).
    step, out_step : grids of the warp (:func:`puppet.video.warp.skeleton_maps`).
    plate : refill the character's place from the background seen on earlier frames
        where there is one (:class:`puppet.video.plate.Plate`; inpainting elsewhere).
    timer : when given, seconds spent per stage are added to it
        (``decode``, ``segment``, ``track``, ``deform``).
    """
    if tracker is None:
        tracker = track.Tracker  # looked up now (a test may swap it)
    clock = timer if timer is not None else {}

    def add(stage: str, t0: float) -> float:
        t = time.perf_counter()
        clock[stage] = clock.get(stage, 0.0) + t - t0
        return t

    src = clip_source(plan.data)
    clean = Plate() if plate else None
    names, k = plan.names, len(plan.names)
    seg = trk = None
    frames = prefetch(src, plan.start, plan.last + 1, partial=True)
    t = time.perf_counter()
    for i, rgba in frames:
        t = add("decode", t)
        mask = seg(rgba) if seg is not None else None
        if seg is None:
            seg = Segmenter(plan.layer, rgba, scene_file=plan.data.file)
            mask = seg(rgba)
        t = add("segment", t)
        lost, reason = False, ""
        if trk is None:
            J = plan.P - HALF
            trk = tracker(rgba, dict(zip(names, map(tuple, J))), mask=mask)
            conf = np.ones(k)
        elif i in plan.anchors:
            trk.reanchor(rgba, {n: (x - HALF, y - HALF) for n, (x, y) in plan.anchors[i].items()}, mask)
            J = np.asarray(trk.held, np.float64) if hasattr(trk, "held") else J
            for n, (x, y) in plan.anchors[i].items():
                J[names.index(n)] = (x - HALF, y - HALF)
            conf = np.array([1.0 if n in plan.anchors[i] else 0.5 for n in names])
        else:
            st = trk.step(rgba, mask=mask)
            J = np.array([st.joints[n] for n in names], np.float64)
            conf = np.array([st.confidence[n] for n in names], np.float64)
            lost, reason = st.lost, st.reason
        t = add("track", t)
        rgb = np.ascontiguousarray(rgba[..., :3])
        if i < plan.first:
            if clean is not None:
                clean.apply(rgb, mask, rgb)  # learn the background only
            continue
        out = _deform(rgb, mask, J, plan, step, out_step, skeleton_maps, background_fill, composite, clean)
        t = add("deform", t)
        yield FrameResult(index=i, rgb=out, joints=J + HALF, confidence=conf, lost=lost, reason=reason)
        t = time.perf_counter()
    plan.ended = src.ended


def _deform(rgb, mask, J, plan, step, out_step, skeleton_maps, background_fill, composite, clean=None) -> np.ndarray:
    """The frame re-posed from joints ``J`` (OpenCV coordinates) to the relative-form targets."""
    Tf = plan.rel.apply(J)
    for s in (step, max(2, step // 2)):  # joints closer than a grid step: a finer grid
        try:
            maps = skeleton_maps(mask, J, Tf, plan.bones, step=s, out_step=out_step)
            break
        except ValueError:
            continue
    else:
        return rgb.copy()
    bg = background_fill(rgb, mask, plan.inpaint)
    if clean is not None:
        bg = clean.apply(rgb, mask, bg)
    return composite(rgb, bg, mask, maps)
