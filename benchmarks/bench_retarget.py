"""Retargeting speed: a 10 s clip onto the T-rex, the whole ``puppet retarget`` and its parts.

Run from the repository root::

    python benchmarks/bench_retarget.py [--seconds 10] [--repeat 3]

The clip is ``assets/motion/walk.bvh`` (30 fps, 34 joints) played over and over until it
lasts ``--seconds`` (its rows repeated: the root jumps back at each repeat, which costs
the key thinning more keys, not less). ``puppet retarget`` runs in this process
(:func:`puppet.cli.main`) onto ``assets/scenes/trex-layers.json``; then its parts alone:
reading the BVH, forward kinematics of every frame, the retargeting (projection, map,
scale, contact) and the key thinning. Wall and CPU seconds, best of ``--repeat``, with
the load average (CPU s counts the child process too). The issue's target: at most 5 s for a 10 s clip onto the T-rex.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import puppet  # noqa: E402
from puppet.cli import main  # noqa: E402
from puppet.motion.bvh import parse_bvh  # noqa: E402
from puppet.motion.retarget import animation, retarget  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLIP = os.path.join(ROOT, "assets", "motion", "walk.bvh")
SCENE = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")


def long_clip(seconds: float) -> str:
    """``walk.bvh`` with its rows repeated until it lasts ``seconds``."""
    text = open(CLIP, encoding="utf-8").read()
    head, motion = text.split("MOTION", 1)
    lines = [line for line in motion.splitlines() if line.strip()]
    dt = float(lines[1].split(":")[1])
    rows = lines[2:]
    n = int(round(seconds / dt)) + 1
    rows = (rows * (n // len(rows) + 1))[:n]
    return f"{head}MOTION\nFrames: {n}\nFrame Time: {dt}\n" + "\n".join(rows) + "\n"


def _cpu() -> float:
    """CPU seconds of this process and its finished children."""
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + ch.ru_utime + ch.ru_stime


def timed(fn, repeat: int):
    best = (float("inf"), float("inf"), None)
    for _ in range(repeat):
        w, c = time.perf_counter(), _cpu()
        out = fn()
        w, c = time.perf_counter() - w, _cpu() - c
        if w < best[0]:
            best = (w, c, out)
    return best


def run(seconds: float, repeat: int) -> None:
    text = long_clip(seconds)
    with tempfile.TemporaryDirectory() as tmp:
        clip = os.path.join(tmp, "clip.bvh")
        with open(clip, "w", encoding="utf-8") as f:
            f.write(text)
        out = os.path.join(tmp, "out.json")
        rows = [("python -m puppet retarget (a fresh process)",) + timed(
            lambda: subprocess.run([sys.executable, "-m", "puppet", "retarget", SCENE, clip, "-o", out],
                                   check=True, capture_output=True), repeat)[:2]]
        rows.append(("puppet retarget (whole command)",) + timed(
            lambda: main(["retarget", SCENE, clip, "-o", out]), repeat)[:2])
        w, c, m = timed(lambda: parse_bvh(text, file=clip), repeat)
        rows.append(("read the BVH", w, c))
        rows.append(("forward kinematics, every frame", *timed(m.positions, repeat)[:2]))
        pins = {p.name: p.at for p in puppet.load_scene(SCENE).data.pins if p.kind != "starch"}
        w, c, r = timed(lambda: retarget(m, pins), repeat)
        rows.append(("retarget (project, map, scale, contact)", w, c))
        w, c, a = timed(lambda: animation(r), repeat)
        rows.append(("key thinning (0.5 px)", w, c))
    load = os.getloadavg()[0]
    print(f"{m.count} frames ({seconds:g} s at {1 / m.frame_time:.0f} fps), {len(m.joints)} joints -> "
          f"{len(r.map)} pins, {len(a['keys'])} keys; load average {load:.2f}; best of {repeat}")
    print(f"{'part':42s} {'wall s':>8s} {'CPU s':>8s}")
    for name, w, c in rows:
        print(f"{name:42s} {w:8.3f} {c:8.3f}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    run(a.seconds, a.repeat)
