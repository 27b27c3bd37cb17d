"""``puppet video`` end to end at 640x480 (issue 13 target: >= 8 frames per second).

The clip is the Kenney toon adventurer walking back and forth (``assets/kenney-toon``,
the same frames as ``walk.json``), encoded once as H.264 MP4 into a temporary folder,
so decoding is a real video decode. Each run re-poses every frame with the scene's
``wave`` pose and encodes the result to MP4, like the command (without its start-up).

Printed per run: end-to-end frames per second (wall clock), CPU ms per frame (all
threads), and ms per frame of each stage: decode (waiting for the decoder thread),
segment, track, deform (relative targets, skeleton MLS on the grid, backward map,
background fill, composite), encode (measured apart, on the same frames). A second row
replaces the SIFT tracker by the clip's known motion (a stand-in that only moves the
joints) to show what the rest of the pipeline costs.

    .venv/bin/python benchmarks/bench_video_pipeline.py [--frames 96] [--repeat 2]
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOON = os.path.join(ROOT, "assets", "kenney-toon")


def _walk_module():
    spec = importlib.util.spec_from_file_location("make_walk", os.path.join(TOON, "make_walk.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def make_clip(folder: str, n: int) -> tuple[str, list[float]]:
    """Write ``walk.mp4`` (n frames) and ``scene.json`` in ``folder``; the clip's x offsets."""
    import av

    walk = _walk_module()
    path = os.path.join(folder, "walk.mp4")
    with av.open(path, "w") as box:
        st = box.add_stream("libx264", rate=12)
        st.width, st.height, st.pix_fmt = walk.W, walk.H, "yuv420p"
        st.options = {"crf": "16", "preset": "veryfast"}
        for a in walk.walk_frames(n):
            for p in st.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(a), format="rgb24")):
                box.mux(p)
        for p in st.encode():
            box.mux(p)
    with open(os.path.join(TOON, "walk.json")) as f:
        scene = json.load(f)
    scene["source"] = "walk.mp4"
    scene["video"] = {"start": 0}
    with open(os.path.join(folder, "scene.json"), "w") as f:
        json.dump(scene, f)
    xs = []
    for i in range(n):
        j = i % (2 * (walk.N - 1))
        j = j if j < walk.N else 2 * (walk.N - 1) - j
        xs.append(10.0 * j)
    return os.path.join(folder, "scene.json"), xs


class KnownMotion:
    """Tracker stand-in: joints follow the clip's known horizontal motion (no image work)."""

    xs: list[float] = []

    def __init__(self, first, joints, mask=None):
        self.j0 = dict(joints)
        self.i = 0

    def step(self, frame, mask=None):
        from puppet.video.track import TrackStep

        self.i += 1
        dx = self.xs[self.i] - self.xs[0]
        return TrackStep({k: (x + dx, y) for k, (x, y) in self.j0.items()}, {k: 1.0 for k in self.j0})


def run_once(scene_path: str, out: str, tracker=None) -> dict:
    import puppet
    from puppet.video.encode import write_frames
    from puppet.video.pipeline import plan_video, run_video

    doc = puppet.load_scene(scene_path)
    plan = plan_video(doc, "wave")
    timer: dict[str, float] = {}
    kept: list[np.ndarray] = []

    def frames():
        for res in run_video(plan, tracker=tracker, timer=timer):
            kept.append(res.rgb)
            yield res.rgb

    w0, c0 = time.perf_counter(), time.process_time()
    n = write_frames(out, frames(), plan.fps, "mp4", plan.size)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    t = time.perf_counter()
    write_frames(out, iter(kept), plan.fps, "mp4", plan.size)  # the encoder alone, on the same frames
    timer["encode"] = time.perf_counter() - t
    return {"frames": n, "fps": n / wall, "cpu_ms": 1e3 * cpu / n,
            **{k: 1e3 * v / n for k, v in timer.items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=96)
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    folder = tempfile.mkdtemp(prefix="puppet-bench-video-")
    try:
        scene, xs = make_clip(folder, args.frames)
        KnownMotion.xs = xs
        print(f"load average {os.getloadavg()[0]:.2f}; {args.frames} frames at 640x480, 'wave' pose")
        stages = ("decode", "segment", "track", "deform", "encode")
        print(f"{'tracker':<14}{'run':>4}{'fps':>7}{'cpu ms/f':>10}" + "".join(f"{s:>9}" for s in stages))
        for name, tracker in (("SIFT", None), ("known motion", KnownMotion)):
            for r in range(args.repeat):
                res = run_once(scene, os.path.join(folder, "out.mp4"), tracker)
                print(f"{name:<14}{r + 1:>4}{res['fps']:>7.1f}{res['cpu_ms']:>10.0f}"
                      + "".join(f"{res.get(s, 0.0):>9.1f}" for s in stages))
        print("stage columns: ms per frame (encode measured apart; it overlaps the rest in a thread)")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
