"""Start-up: how long ``puppet render`` takes from the shell, beside its floors.

Run:  python benchmarks/bench_startup.py [--rounds R]
Every row is a fresh process, timed from the parent (wall clock), rounds interleaved so
that all rows see the same machine load. Rows: the interpreter alone; ``import numpy``;
numpy + ``scipy.sparse`` (what the solvers need; SciPy 1.17's array-API layer imports
numpy.testing, f2py, ma, random... while loading); ``puppet --version`` (the command's own
start); ``puppet render`` of the T-rex at its canvas size (the issue's target: <= 0.8 s);
and the same render in a warm process (scene loaded and drawn once before, so imports,
EGL and shader compilation are paid already): what is left is the real work.
Bytecode caches are allowed (a user's Python writes them on the first run), whatever
PYTHONDONTWRITEBYTECODE says in this shell.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SCENE = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
BIN = os.path.dirname(sys.executable)


def rows(out: str) -> dict[str, list[str]]:
    puppet = os.path.join(BIN, "puppet")
    py = sys.executable
    warm = (
        "import time, puppet; s = puppet.load_scene({scene!r}); s.render(pose='wave');"
        "t = time.perf_counter(); s = puppet.load_scene({scene!r}); s.render(pose='wave');"
        "print(time.perf_counter() - t)").format(scene=SCENE)
    return {
        "python -c pass": [py, "-c", "pass"],
        "import numpy": [py, "-c", "import numpy"],
        "import numpy, scipy.sparse": [py, "-c", "import numpy, scipy.sparse"],
        "puppet --version": [puppet, "--version"],
        "puppet render trex --pose wave": [puppet, "render", SCENE, "--pose", "wave", "-o", out],
        "(in a warm process: load + render)": [py, "-c", warm],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    with tempfile.TemporaryDirectory() as tmp:
        table = rows(os.path.join(tmp, "trex.png"))
        times: dict[str, list[float]] = {k: [] for k in table}
        for cmd in table.values():  # once untimed: bytecode caches written
            subprocess.run(cmd, env=env, check=True, capture_output=True)
        for _ in range(args.rounds):
            for name, cmd in table.items():
                t = time.perf_counter()
                r = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True)
                wall = time.perf_counter() - t
                times[name].append(float(r.stdout) if name.startswith("(") else wall)
    load = os.getloadavg()[0]
    print(f"start-up, seconds, {args.rounds} rounds (load {load:.2f} at the end)")
    print(f"{'':38s} {'best':>7s} {'median':>7s}")
    for name, ts in times.items():
        print(f"{name:38s} {min(ts):7.3f} {statistics.median(ts):7.3f}")


if __name__ == "__main__":
    main()
