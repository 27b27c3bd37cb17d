"""Export time and size of the mesh formats (web player ``.html``, Spine ``.spine.json``)
against the MP4 export of the same animation.

Run from the repository root::

    python benchmarks/bench_export_formats.py [--scenes character trex] [--seconds 1] [--fps 24]
        [--runs 2] [--formats mp4 html spine gif]

Two measures per format, each run ``--runs`` times:

* ``cli s``: ``python -m puppet animate SCENE -o OUT --to SECONDS --fps FPS`` in a fresh
  process, wall time (what a user waits for: imports, scene build, GL context when the
  format draws, every frame, writing);
* ``export s``: :func:`puppet.anim.export.animate_to` in this process on a scene already
  loaded and built (after one warm-up export of the same format): the export alone.

``x mp4`` is the median of each measure over the median of MP4's. ``size`` is the bytes
written (all files: Spine's JSON + atlas + page PNG).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the `puppet` command does (before numpy)
os.environ.setdefault("PUPPET_BLAS_SET_AT_START", "1")

import argparse  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

SCENES = {"character": "assets/scenes/character.json", "trex": "assets/scenes/trex-layers.json"}
OUTS = {"mp4": "out.mp4", "html": "out.html", "spine": "out.spine.json", "gif": "out.gif", "webm": "out.webm",
        "glb": "out.glb"}


def cli_time(scene: str, out: str, seconds: float, fps: float) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "puppet", "animate", scene, "-o", out, "--to", str(seconds),
                    "--fps", str(fps)], check=True, cwd=ROOT, env=dict(os.environ, PYTHONPATH=ROOT))
    return time.perf_counter() - t


def written(folder: str) -> int:
    return sum(os.path.getsize(os.path.join(folder, f)) for f in os.listdir(folder))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--formats", nargs="+", default=["mp4", "html", "spine"], choices=list(OUTS))
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--fps", type=float, default=24.0)
    ap.add_argument("--runs", type=int, default=2)
    args = ap.parse_args()

    import puppet
    from puppet.anim.export import animate_to

    print(f"load: {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} cores; {args.seconds:g} s at {args.fps:g} fps")
    print(f"{'scene':10s} {'format':6s} {'frames':>6s} {'cli s':>14s} {'x mp4':>6s} {'export s':>14s} "
          f"{'x mp4':>6s} {'size':>10s}")
    for name in args.scenes:
        path = os.path.join(ROOT, SCENES[name])
        scene = puppet.load_scene(path)
        scene.built  # noqa: B018
        base = {}
        for fmt in args.formats:
            tmp = tempfile.mkdtemp(prefix="puppet-bench-")
            out = os.path.join(tmp, OUTS[fmt])
            try:
                cli = [cli_time(path, out, args.seconds, args.fps) for _ in range(args.runs)]
                size = written(tmp)
                n = animate_to(scene, out, end=args.seconds, fps=args.fps)  # warm-up
                inproc = []
                for _ in range(args.runs):
                    t = time.perf_counter()
                    animate_to(scene, out, end=args.seconds, fps=args.fps)
                    inproc.append(time.perf_counter() - t)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
            med = (statistics.median(cli), statistics.median(inproc))
            base.setdefault("mp4", med if fmt == "mp4" else None)
            ref = base.get("mp4")
            ratio = [f"{m / r:6.2f}" if ref else "     -" for m, r in zip(med, ref or (1, 1))]
            print(f"{name:10s} {fmt:6s} {n:6d} {' '.join(f'{v:6.2f}' for v in cli):>14s} {ratio[0]} "
                  f"{' '.join(f'{v:6.2f}' for v in inproc):>14s} {ratio[1]} {size:10d}")
        scene.close()


if __name__ == "__main__":
    main()
