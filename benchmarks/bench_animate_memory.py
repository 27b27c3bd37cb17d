"""Peak memory of ``puppet animate`` against the number of frames (GIF and MP4 stream).

Run: ``python benchmarks/bench_animate_memory.py [--frames 100 10000] [--formats gif mp4]
[--scene assets/scenes/trex-layers.json] [--size 640x480] [--fps 24]`` from the repository root.

A copy of the scene (image paths made absolute) gets an animation of exactly N frames at
``--fps``: its keys' poses are cycled forward and back at the original key spacing. Each
export runs ``python -m puppet animate`` in a fresh process; its peak resident memory is
read from ``wait4`` (the same number ``/usr/bin/time -v`` prints). The table gives, per
format and frame count, the wall time, frames per second, peak RSS and its ratio to the
smallest run of that format. Streaming keeps the ratio near 1; a writer that holds every
frame grows by ~1.2 MB per 640x480 frame.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def absolute_paths(scene: dict, folder: str) -> dict:
    """The scene JSON with every file path made absolute (so the copy can live anywhere)."""
    def fix(p):
        return os.path.normpath(os.path.join(folder, p))

    for key in ("source", "background"):
        if isinstance(scene.get(key), str):
            scene[key] = fix(scene[key])
    for layer in scene["layers"]:
        if "image" in layer:
            layer["image"] = fix(layer["image"])
        if isinstance(layer.get("mask"), dict) and "file" in layer["mask"]:
            layer["mask"]["file"] = fix(layer["mask"]["file"])
    return scene


def long_animation(scene: dict, frames: int, fps: float) -> dict:
    """An animation of exactly ``frames`` frames: the keys' poses ping-ponged at their spacing."""
    keys = scene["animation"]["keys"]
    poses = [k["pose"] for k in keys]
    cycle = poses + poses[-2:0:-1] if len(poses) > 1 else poses
    dt = (keys[-1]["time"] - keys[0]["time"]) / max(len(keys) - 1, 1) or 0.5
    end = (frames - 1) / fps
    out, i = [], 0
    while i * dt < end - 1e-9:
        out.append({"time": round(i * dt, 6), "pose": cycle[i % len(cycle)]})
        i += 1
    out.append({"time": end, "pose": cycle[i % len(cycle)]})
    scene["animation"] = {"fps": fps, "keys": out}
    return scene


def run(scene_path: str, out: str, size: str) -> tuple[float, float, int]:
    """(seconds, peak RSS in MB, exit status) of one ``puppet animate`` in a fresh process."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "puppet", "animate", scene_path, "-o", out, "--size", size],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode()
    if proc.returncode:
        print(f"  failed ({proc.returncode}): {err.strip()}", file=sys.stderr)
    return time.perf_counter() - t0, usage.ru_maxrss / 1024.0, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "assets", "scenes", "trex-layers.json"))
    ap.add_argument("--frames", type=int, nargs="+", default=[100, 10000])
    ap.add_argument("--formats", nargs="+", default=["gif", "mp4"])
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--fps", type=float, default=24.0)
    args = ap.parse_args()
    with open(args.scene) as f:
        base = absolute_paths(json.load(f), os.path.dirname(os.path.abspath(args.scene)))
    work = tempfile.mkdtemp(prefix="bench_animate_")
    try:
        print(f"scene {os.path.relpath(args.scene, ROOT)}, {args.size}, {args.fps:g} fps")
        print(f"{'format':>6} {'frames':>7} {'seconds':>9} {'frames/s':>9} {'peak RSS MB':>12} {'ratio':>6}")
        for fmt in args.formats:
            first = None
            for n in args.frames:
                scene = long_animation(json.loads(json.dumps(base)), n, args.fps)
                path = os.path.join(work, f"scene_{n}.json")
                with open(path, "w") as f:
                    json.dump(scene, f)
                out = os.path.join(work, f"out_{n}.{fmt}")
                secs, rss, rc = run(path, out, args.size)
                first = first or rss
                mb = os.path.getsize(out) / 2**20 if rc == 0 else float("nan")
                print(f"{fmt:>6} {n:>7} {secs:>9.1f} {n / secs:>9.1f} {rss:>12.0f} {rss / first:>6.2f}"
                      f"   ({mb:.1f} MB file)", flush=True)
                if os.path.exists(out):
                    os.remove(out)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
