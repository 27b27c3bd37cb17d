"""``puppet video``: its arguments and how it runs (imported by puppet.cli; keep it cheap to import)."""
from __future__ import annotations

import argparse
import sys

import puppet
from puppet.errors import SceneError
from puppet.output import Staged, check_file, check_folder, commit_all


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    v = sub.add_parser("video", help="re-pose a character through a video whose first frame holds the skeleton")
    v.add_argument("scene")
    v.add_argument("--pose", required=True, metavar="NAME", help="the target skeleton: a pose of the scene")
    v.add_argument("-o", "--output", required=True, metavar="OUT.mp4|OUT.webm|OUT_DIR/")
    v.add_argument("--tracks", metavar="TRACKS.json", help="also write the tracked joints")
    v.add_argument("--anchors", metavar="ANCHORS.json",
                   help='re-place the skeleton on given frames: {"FRAME": {"PIN": [x, y]}}')
    v.add_argument("--from", dest="start", type=int, metavar="N", help="first frame (default: the scene's start frame)")
    v.add_argument("--to", dest="end", type=int, metavar="M", help="last frame (default: the last)")
    return v


def _ranges(frames: list[int]) -> str:
    """``3-5, 9`` from sorted frame numbers."""
    out, i = [], 0
    while i < len(frames):
        j = i
        while j + 1 < len(frames) and frames[j + 1] == frames[j] + 1:
            j += 1
        out.append(f"{frames[i]}" if i == j else f"{frames[i]}-{frames[j]}")
        i = j + 1
    return ", ".join(out)


def run(args: argparse.Namespace) -> int:
    """Validate everything, then stream the re-posed frames to the output; 0 on success."""
    import numpy as np

    from puppet.video.encode import output_kind, write_frames  # lazy: numpy (the CLI's parser imports this module)

    kind = output_kind(args.output)
    check = check_folder if kind == "dir" else check_file
    check(args.output, probe=True, **({"contents": False} if kind == "dir" else {}))
    if args.tracks:
        if not args.tracks.lower().endswith(".json"):
            raise SceneError(f"--tracks {args.tracks!r}: give a .json file")
        check_file(args.tracks, probe=True)

    from puppet.scene.format.inputs import input_files  # lazy: as above
    from puppet.video.pipeline import plan_video, read_anchors, run_video  # lazy: as above

    scene = puppet.load_scene(args.scene)
    anchors = read_anchors(args.anchors) if args.anchors else None
    plan = plan_video(scene, args.pose, first=args.start, last=args.end, anchors=anchors)
    inputs = input_files(scene.data) + ([(args.anchors, "--anchors")] if args.anchors else [])
    check(args.output, inputs=inputs)
    if args.tracks:
        check_file(args.tracks, inputs=inputs)
    scene.built  # noqa: B018  (the start frame's masks and meshes: a pin off the character fails here)

    n = plan.count
    joints = {name: np.full((n, 2), np.nan) for name in plan.names}
    conf = {name: np.zeros(n) for name in plan.names}
    lost: list[int] = []

    def frames():
        bar = None
        if sys.stderr.isatty():
            from tqdm import tqdm

            bar = tqdm(total=n, unit="frame", desc="puppet video", file=sys.stderr, leave=False)
        try:
            for res in run_video(plan):
                j = res.index - plan.first
                for c, name in enumerate(plan.names):
                    if not res.lost:
                        joints[name][j] = res.joints[c]
                    conf[name][j] = res.confidence[c]
                if res.lost:
                    lost.append(res.index)
                if bar is not None:
                    bar.update(1)
                yield res.rgb
        finally:
            if bar is not None:
                bar.close()

    staged = []

    def then(count: int) -> None:  # every frame is written; the output is not in place yet
        if count == 0:
            raise SceneError(f"video {plan.data.source!r}: ends before frame {plan.first} (--from)",
                             file=plan.data.file, path="source")
        if args.tracks:
            staged.append(_stage_tracks(args.tracks, plan, joints, conf, lost, count,
                                        inputs + [(args.output, "-o")]))

    try:
        written = write_frames(args.output, frames(), plan.fps, kind, plan.size, inputs=inputs, then=then)
    except BaseException:
        for s in staged:
            s.discard()
        raise
    try:
        commit_all(staged)
    except BaseException:  # the video is in place, its tracks are not: take it back
        _take_back(args.output, kind)
        raise
    if plan.ended is not None:
        print(f"puppet: warning: {plan.data.file}: video {plan.data.source!r} ends at frame {plan.ended[0]} "
              f"although it declares {plan.data.video['count']} frames ({plan.ended[1]}): wrote frames "
              f"{plan.first}-{plan.first + written - 1} only", file=sys.stderr)
    if lost:
        print(f"puppet: tracking lost on {len(lost)} of {written} frames: {_ranges(lost)} "
              f"(the skeleton was held; re-place it there with --anchors)", file=sys.stderr)
    return 0


def _take_back(path: str, kind: str) -> None:
    """Remove the output just put in place (where a symlink named as ``-o`` points)."""
    import contextlib
    import os
    import shutil

    real = os.path.realpath(path.rstrip("/" + os.sep) or os.sep)
    with contextlib.suppress(OSError):
        if kind == "dir":
            shutil.rmtree(real)
        else:
            os.remove(real)


def _stage_tracks(path: str, plan, joints: dict, conf: dict, lost: list[int], count: int, inputs):
    """The ``--tracks`` file of the ``count`` frames written, staged (:class:`puppet.output.Staged`)."""
    import json

    from puppet.video.track import Tracks  # lazy: numpy (the CLI's parser imports this module)

    doc = Tracks(joints={n: xy[:count] for n, xy in joints.items()}, confidence={n: c[:count] for n, c in conf.items()},
                 lost_frames=lost).to_json(plan.fps, plan.size)
    text = json.dumps(doc) + "\n"

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    return Staged(path, write, inputs=inputs)
