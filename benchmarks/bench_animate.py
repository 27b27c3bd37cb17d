"""Export speed: N frames of the T-rex animation at 1280x720 to MP4 and to a PNG folder,
pipelined (solve | composite | encode on three threads) and, with ``--sequential``, one
stage after the other; then peak memory of ``puppet animate`` at two frame counts.

Run from the repository root::

    python benchmarks/bench_animate.py [--frames 1000] [--size 1280x720] [--formats mp4 dir]
        [--sequential] [--memory 1000 10000] [--memory-size 160x120] [--memory-format mp4]
        [--workers 1 2] [--solve-rate 1 2] [--repeat 2]

The scene is ``assets/scenes/trex-layers.json`` with its poses cycled forward and back at
the key spacing until the animation holds exactly N frames at 24 fps (see
``bench_animate_memory.long_animation``). Part 1 runs :func:`puppet.anim.export.animate_to`
in this process (one BLAS thread, as the ``puppet`` command sets it) after a warm-up
frame, and prints wall time, frames per second and where the time went: milliseconds per
frame of each stage's work (``--solvers thread process`` compares solving on a thread
with solving in a child process; ``solve``: in-betweens and ARAP on the solver thread;
``composite``: GL draw and read-back on the main thread; ``encode``: PNG deflate / x264
on the encoder thread) and of the main thread waiting (``wait``: for a solved frame or
for room at the encoder). In the pipelined run the stages overlap, so their sum exceeds
the wall time; each stage slows down when it shares the 2 cores. ``CPU s`` counts this
process and the solver process. Part 2 runs ``python -m
puppet animate`` in fresh processes and reads the peak RSS from ``wait4``.

``--workers 1 2`` runs each pipelined export with that many solver processes
(``animate_to(workers=N)``; 1: the solver thread). With two or more, the processes also
draw and encode the frames (their ``composite`` and ``encode`` are summed over them, as
``solve`` is); ``--drawing there here`` also times each such export drawn here as before
issue 31's part X (the processes only solve), in the same run (path ``.../2p/here``). Part 0, ``--solve-rate 1 2``, measures
the solve alone (no drawing, no encoding): the frames are solved by a
:class:`puppet.anim.solver.SolverPool` of N processes (started and warmed up first) and
handed back in order; it prints frames per second, the ratio to the first N of the same
round, and CPU milliseconds per frame in the solver processes (``/proc/PID/stat``) and
in this process (receiving), the seconds the processes took to start (a fresh
``python`` each: imports, the scene built, the first frame checked), with the load
average; ``--repeat`` rounds alternate the counts. Linux groups the CPU time of a
terminal session (``sched_autogroup``): on a machine busy with other sessions, N
processes share one session's share and their frames/s hardly grows with N (the CPU time
a frame takes tells the scaling then).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the `puppet` command does (before numpy)
os.environ.setdefault("PUPPET_BLAS_SET_AT_START", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from benchmarks.bench_animate_memory import absolute_paths, long_animation, run  # noqa: E402

STAGES = ("solve", "composite", "encode", "wait")


def scene_file(base: dict, frames: int, fps: float, folder: str) -> str:
    path = os.path.join(folder, f"trex_{frames}.json")
    with open(path, "w") as f:
        json.dump(long_animation(json.loads(json.dumps(base)), frames, fps), f)
    return path


def child_cpu(pids: list[int]) -> float:
    """CPU seconds (user + system) the processes have used so far."""
    total = 0.0
    for pid in pids:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def solve_rate(path: str, n: int, frames: int) -> tuple[float, float, float, float]:
    """(frames/s, solver processes' CPU s a frame, this process's CPU s a frame, seconds
    to start the processes) of ``frames`` frames solved by ``n`` processes and received
    here in order."""
    import puppet
    from puppet.anim.solver import SolverPool

    scene = puppet.load_scene(path)
    rate = scene.data.animation.fps
    pool = SolverPool(scene, 0.0, rate, n)
    start = time.perf_counter()
    assert pool.start(0), "the solver processes do not solve as this process"
    start = time.perf_counter() - start
    try:
        list(pool.results([1] * (2 * n), lambda: False))  # every child warm
        pids = [s.proc.pid for s in pool.solvers]
        c0, p0, t0 = child_cpu(pids), time.process_time(), time.perf_counter()
        got = sum(1 for _ in pool.results(list(range(frames)), lambda: False))
        wall = time.perf_counter() - t0
        cpu, mine = child_cpu(pids) - c0, time.process_time() - p0
    finally:
        pool.close()
    return got / wall, cpu / got, mine / got, start


def speed(path: str, out: str, size: tuple[int, int], threads: bool, solver: str = "auto",
          workers: int | None = None, here: bool = False) -> tuple[int, float, float, dict]:
    """(frames, wall seconds, CPU seconds, per-stage seconds) of one in-process export
    (``here``: solver processes only solve, the frames are drawn in this process)."""
    import puppet
    from puppet.anim import export
    from puppet.anim.pipeline import Timings

    def animate_to(*a, **k):
        real = export._draw_there
        if here:
            export._draw_there = lambda *a: False
        try:
            return export.animate_to(*a, **k)
        finally:
            export._draw_there = real

    scene = puppet.load_scene(path)
    scene.render(time=0.0, size=size)  # GL context, textures, solver precomputation
    import resource

    def cpu_now() -> float:  # this process and its ended children (the solver process)
        a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime

    tm = Timings()
    t0, c0 = time.perf_counter(), cpu_now()
    n = animate_to(scene, out, size=size, threads=threads, solver=solver, timings=tm, workers=workers)
    wall, cpu = time.perf_counter() - t0, cpu_now() - c0
    scene.close()
    return n, wall, cpu, dict(tm)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "assets", "scenes", "trex-layers.json"))
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--fps", type=float, default=24.0)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--formats", nargs="*", default=["mp4", "dir"], choices=["mp4", "dir", "webm", "apng", "gif"])
    ap.add_argument("--sequential", action="store_true", help="also time the sequential path")
    ap.add_argument("--solvers", nargs="+", default=["auto"], choices=["auto", "thread", "process"],
                    help="pipelined runs: where frames are solved (auto: a thread)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1], help="solver processes of the pipelined runs")
    ap.add_argument("--drawing", nargs="+", default=["there"], choices=["there", "here"],
                    help="with 2+ workers: frames drawn and encoded in the solver processes, or here")
    ap.add_argument("--solve-rate", type=int, nargs="*", default=[1, 2], help="solver processes (none: skip)")
    ap.add_argument("--repeat", type=int, default=2, help="rounds of the solve-rate table")
    ap.add_argument("--memory", type=int, nargs="*", default=[1000, 10000], help="frame counts (none: skip)")
    ap.add_argument("--memory-size", default="160x120")
    ap.add_argument("--memory-format", default="mp4")
    args = ap.parse_args()
    size = tuple(int(x) for x in args.size.lower().split("x"))
    with open(args.scene) as f:
        base = absolute_paths(json.load(f), os.path.dirname(os.path.abspath(args.scene)))
    work = tempfile.mkdtemp(prefix="bench_animate_")
    try:
        print(f"load average {os.getloadavg()[0]:.2f}; {os.cpu_count()} cores; "
              f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', '(unset)')}")
        path = scene_file(base, args.frames, args.fps, work)
        if args.solve_rate:
            print(f"\nsolve only: {args.frames} frames of {os.path.relpath(args.scene, ROOT)} in N solver processes")
            print(f"{'round':>5} {'N':>3} {'frames/s':>9} {'x first':>8} {'solver CPU ms/frame':>20} "
                  f"{'here CPU ms/frame':>18} {'start s':>8} {'load':>5}")
            for r in range(args.repeat):
                first = None
                for k in args.solve_rate:
                    fps, cpu, mine, start = solve_rate(path, k, args.frames)
                    first = first or fps
                    print(f"{r + 1:>5} {k:>3} {fps:>9.1f} {fps / first:>8.2f} {1e3 * cpu:>20.1f} "
                          f"{1e3 * mine:>18.1f} {start:>8.2f} {os.getloadavg()[0]:>5.2f}", flush=True)
        print(f"\n{args.frames} frames of {os.path.relpath(args.scene, ROOT)} at {args.size}")
        print(f"{'format':>6} {'path':>17} {'seconds':>8} {'frames/s':>8} {'CPU s':>6} | ms/frame:"
              + " ".join(f"{s:>9}" for s in STAGES) + f" {'load':>5}")
        runs = [(True, s, w, d == "here") for s in args.solvers for w in args.workers
                for d in (args.drawing if w > 1 else ["there"])] \
            + ([(False, "-", 1, False)] if args.sequential else [])
        for fmt in args.formats:
            for threads, solver, workers, here in runs:
                out = os.path.join(work, "frames/" if fmt == "dir" else f"out.{fmt}")
                n, wall, cpu, tm = speed(path, out, size, threads, solver if threads else "auto", workers, here)
                stages = " ".join(f"{1e3 * tm.get(s, 0.0) / n:>9.1f}" for s in STAGES) + f" {os.getloadavg()[0]:>5.2f}"
                name = (f"pipe/{solver}" + (f"/{workers}p" if workers > 1 else "") + ("/here" if here else "")) \
                    if threads else "sequential"
                print(f"{fmt:>6} {name:>17} {wall:>8.1f} {n / wall:>8.1f} "
                      f"{cpu:>6.1f} | {stages}", flush=True)
                shutil.rmtree(out, ignore_errors=True) if fmt == "dir" else os.remove(out)
        if args.memory:
            print(f"\npeak memory of `puppet animate` ({args.memory_format}, {args.memory_size}), "
                  f"load average {os.getloadavg()[0]:.2f}")
            print(f"{'frames':>7} {'seconds':>8} {'frames/s':>8} {'peak RSS MB':>12} {'ratio':>6}")
            first = None
            for n in args.memory:
                p = scene_file(base, n, args.fps, work)
                out = os.path.join(work, f"mem.{args.memory_format}")
                secs, rss, rc = run(p, out, args.memory_size)
                first = first or rss
                print(f"{n:>7} {secs:>8.1f} {n / secs:>8.1f} {rss:>12.0f} {rss / first:>6.2f}"
                      + ("" if rc == 0 else "  FAILED"), flush=True)
                if os.path.exists(out):
                    os.remove(out)
        print(f"\nload average at the end {os.getloadavg()[0]:.2f}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
