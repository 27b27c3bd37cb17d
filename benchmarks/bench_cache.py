"""Load + first render of a scene in a new process: without the disk cache, with an empty
one (the first open, which also writes it) and with a full one (the second open).

Run:  python benchmarks/bench_cache.py SCENE.json [--rounds R] [--size W H]
Each row is a fresh process (imports included, as a user runs it) that loads the scene and
renders the rest pose at canvas size (or --size); it reports wall time and the CPU time of
the process (all threads: a loaded machine inflates the wall time more than the CPU time),
medians over the rounds, with the load average. The scene's folder is used as it is: its
``.puppet-cache/`` is deleted before each "empty" row (copy the scene somewhere first if
you want to keep yours).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys

CHILD = r"""
import json, os, sys, time
t0, c0 = time.perf_counter(), time.process_time()
import puppet
s = puppet.load_scene(sys.argv[1])
s.built
t1, c1 = time.perf_counter(), time.process_time()
size = None if sys.argv[2] == "-" else tuple(int(v) for v in sys.argv[2].split("x"))
s.render(size=size)
t2, c2 = time.perf_counter(), time.process_time()
print(json.dumps({"load": t1 - t0, "load_cpu": c1 - c0, "total": t2 - t0, "total_cpu": c2 - c0}))
"""


def run(scene: str, size: str, cache: str) -> dict:
    env = dict(os.environ, PUPPET_CACHE=cache)
    out = subprocess.run([sys.executable, "-c", CHILD, scene, size], env=env, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--size", type=int, nargs=2, default=None)
    args = ap.parse_args()
    scene = os.path.abspath(args.scene)
    folder = os.path.join(os.path.dirname(scene), ".puppet-cache")
    size = "-" if args.size is None else f"{args.size[0]}x{args.size[1]}"
    rows: dict[str, list[dict]] = {"no cache (PUPPET_CACHE=off)": [], "empty cache (first open)": [],
                                   "full cache (second open)": []}
    for _ in range(args.rounds):  # interleaved: every row sees the same load
        rows["no cache (PUPPET_CACHE=off)"].append(run(scene, size, "off"))
        shutil.rmtree(folder, ignore_errors=True)
        rows["empty cache (first open)"].append(run(scene, size, "on"))
        rows["full cache (second open)"].append(run(scene, size, "on"))
    print(f"{os.path.basename(scene)}, {args.rounds} rounds, load average {os.getloadavg()[0]:.2f}")
    print(f"{'':30} {'load s':>8} {'load cpu':>9} {'+render s':>10} {'total cpu':>10}")
    for name, rs in rows.items():
        med = {k: statistics.median(r[k] for r in rs) for k in rs[0]}
        print(f"{name:30} {med['load']:8.2f} {med['load_cpu']:9.2f} {med['total']:10.2f} {med['total_cpu']:10.2f}")


if __name__ == "__main__":
    main()
