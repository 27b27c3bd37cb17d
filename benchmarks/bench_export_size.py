"""Sizes of the keyed mesh exports (issue 32): the 49-frame character clip of
``tests/anim/character_clip.py`` (4 s at 12 fps, 7 moving layers, ~9000 vertices) written
as Spine JSON and as the web player, with a key on every frame (``--tolerance 0``, the
files as written before keys were reduced), with the default tolerance (1 px), and Spine
with lighter meshes (``--simplify 0.5 --tolerance 0.5``: still within 1 px); the file
sizes, the keys written and the CPU time of each export (this process, one BLAS thread).

Run from the repository root::

    python benchmarks/bench_export_size.py [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from puppet.cli import main  # noqa: E402
from tests.anim.character_clip import character_clip  # noqa: E402

RUNS = [("spine", "c.spine.json", ["--tolerance", "0"]), ("spine", "c.spine.json", []),
        ("spine", "c.spine.json", ["--simplify", "0.5", "--tolerance", "0.5"]),
        ("html", "c.html", ["--tolerance", "0"]), ("html", "c.html", [])]


def spine_keys(path: str) -> int:
    with open(path) as f:
        anim = json.load(f)["animations"]["animation"]
    return sum(len(t) for s in anim.get("attachments", {}).get("default", {}).values() for t in
               (v["deform"] for v in s.values()))


def run(folder: str) -> None:
    scene = character_clip(folder)
    print(f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'format':6} {'options':34} {'bytes':>10} {'keys':>6} {'CPU s':>6}")
    for kind, name, extra in RUNS:
        out = os.path.join(folder, name)
        c = time.process_time()
        assert main(["animate", scene, "-o", out, *extra]) == 0
        cpu = time.process_time() - c
        keys = spine_keys(out) if kind == "spine" else ""
        print(f"{kind:6} {' '.join(extra) or '(default)':34} {os.path.getsize(out):>10,} {keys!s:>6} {cpu:6.2f}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", help="folder for the files (default: a temporary one)")
    a = p.parse_args()
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        run(a.out)
    else:
        with tempfile.TemporaryDirectory() as d:
            run(d)
