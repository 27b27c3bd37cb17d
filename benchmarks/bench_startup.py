"""Start-up: how long ``puppet render`` takes from the shell, beside its floors.

Run:  python benchmarks/bench_startup.py [--rounds R] [--compare DIR] [--no-bytecode]
Every row is a fresh process, timed from the parent (wall clock), rounds interleaved so
that all rows see the same machine load. Rows: the interpreter alone; ``import numpy``;
numpy + ``scipy.sparse`` (what the solvers need; SciPy 1.17's array-API layer imports
numpy.testing, f2py, ma, random... while loading); ``puppet --version`` (the command's own
start); ``puppet render`` of the T-rex at its canvas size (the issue's target: <= 0.8 s);
and the same render in a warm process (scene loaded and drawn once before, so imports,
EGL and shader compilation are paid already): what is left is the real work.
Bytecode caches are allowed (a user's Python writes them on the first run), whatever
PYTHONDONTWRITEBYTECODE says in this shell; ``--no-bytecode`` measures the other case (an
editable install under PYTHONDONTWRITEBYTECODE=1: every command compiles puppet's modules
from their source, while numpy's and SciPy's installed caches serve) on a copy of the
package without its caches.

``puppet check`` and ``puppet mesh`` of the T-rex are timed too (the scene's disk cache,
written by the untimed first round, serves them as it serves a user's second command).
``--compare DIR`` adds the same command rows for the puppet package found in DIR (e.g.
``git archive OLD puppet | tar -x -C DIR``), run as ``python -m puppet`` from outside
this checkout (``python -m puppet`` for this one too, so the rows compare like with like).
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SCENE = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
BIN = os.path.dirname(sys.executable)


def command_rows(out: str, tag: str = "") -> dict[str, list[str]]:
    """``puppet`` render, mesh and check of the T-rex (``python -m puppet``)."""
    puppet = [sys.executable, "-m", "puppet"]
    return {
        f"{tag}-m puppet render trex --pose wave": puppet + ["render", SCENE, "--pose", "wave", "-o", out + ".png"],
        f"{tag}-m puppet mesh trex --pose wave": puppet + ["mesh", SCENE, "--pose", "wave", "-o", out + ".json"],
        f"{tag}-m puppet check trex": puppet + ["check", SCENE],
    }


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


def environments(args, tmp: str) -> dict[str, dict]:
    """The environment of the rows' processes: ``""`` this checkout, ``"compared"`` the other."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env.pop("PYTHONPATH", None)
    if args.no_bytecode:  # a copy of the package without bytecode, compiled by every command
        src = os.path.join(tmp, "src")
        skip = shutil.ignore_patterns("__pycache__", "*.pyc")
        shutil.copytree(os.path.join(ROOT, "puppet"), os.path.join(src, "puppet"), ignore=skip)
        shutil.copytree(os.path.join(ROOT, "shaders"), os.path.join(src, "puppet", "shaders"), ignore=skip)
        env.update(PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=src)
    out = {"": env}
    if args.compare:
        out["compared"] = dict(env, PYTHONPATH=os.path.abspath(args.compare))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--compare", metavar="DIR", help="a folder holding another puppet package to time beside this one")
    ap.add_argument("--no-bytecode", action="store_true", help="puppet's modules compiled by every command")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        envs = environments(args, tmp)
        table = rows(os.path.join(tmp, "trex.png"))
        table.update(command_rows(os.path.join(tmp, "this")))
        if args.compare:
            table.update(command_rows(os.path.join(tmp, "other"), "compared "))
        times: dict[str, list[float]] = {k: [] for k in table}
        loads = [os.getloadavg()[0]]

        def run(name, cmd):
            env = envs.get(name.split()[0], envs[""])
            return subprocess.run(cmd, env=env, check=True, capture_output=True, text=True, cwd=tmp)

        for name, cmd in table.items():  # once untimed: bytecode and disk caches written
            run(name, cmd)
        for _ in range(args.rounds):
            for name, cmd in table.items():
                t = time.perf_counter()
                r = run(name, cmd)
                wall = time.perf_counter() - t
                times[name].append(float(r.stdout) if name.startswith("(") else wall)
            loads.append(os.getloadavg()[0])
    load = f"load {min(loads):.2f}-{max(loads):.2f}"
    what = ", puppet compiled by every command" if args.no_bytecode else ""
    print(f"start-up, seconds, {args.rounds} rounds ({load}{what})")
    print(f"{'':44s} {'best':>7s} {'median':>7s}")
    for name, ts in times.items():
        print(f"{name:44s} {min(ts):7.3f} {statistics.median(ts):7.3f}")


if __name__ == "__main__":
    main()
