"""Cost against size (issue 31): one table per run, with the load average and BLAS threads.

Rows (``--sizes``, any of them, in this order by default):

- ``2k``, ``8k``, ``32k``, ``128k``: the bundled T-rex (``assets/scenes/trex-layers.json``,
  8 linked layers) meshed denser: a copy of the scene with one ``mesh.max_area`` for every
  layer. Its art holds 74k opaque pixels, too few for 128k vertices at the format's
  smallest ``max_area`` (0.5 px²), so the 128k copy draws the art twice as big (images
  resized 2x, every coordinate doubled).
- ``psd4k``: the 20-part 4000x4000 PSD (``bench_import.make_psd`` + ``puppet init --pins auto
  --links auto``).
- ``garment``: ``bench_drag``'s 4000x4000 garment photo (``puppet init --alpha --pins auto``).
- ``islands``: the same photo cut into tiles by transparent lines (24 px wide, every 250 px):
  one layer of 165 islands (164 in its mesh), then ``puppet init --alpha --pins auto``.

Columns: vertices and groups of the built scene; the preview ``move`` (``scene.drag(pin).move``,
a preview frame drawn) median and 95th percentile over ``--steps`` points of three quarters
of a circle from a middle pin (the interior pin nearest the pins' centroid; radius 4 % of
the canvas' larger side); the exact release: ``release_layers`` after those moves and
``release`` (the full-size frame drawn) after the mirrored path (the circle on the pin's
left: another end point, since the rig keeps solved poses) walked with ``move_layers``;
the preview error: at 5 points of that path, the last ``move_layers`` against
``release_layers`` of a fresh drag to the same point, over the vertices of the dragged group
that move (px: median / 95th percentile / max; a preview mesh that is not the exact one --
a proxy, a subspace -- is read at the exact mesh's rest vertices through its triangles); load +
first render (``load_scene`` and a full-size ``render()``, timed inside a new process) cold
(the cache folder ``.puppet-cache`` beside the scene removed) and cached (a second new
process; "n/a" when no cache folder appeared). Below the table: ``puppet animate`` of the
bundled T-rex to MP4 against ``--workers`` (frames counted in the file over the command's
wall time, and steady: past a 2-frame export's time; "n/a" when ``animate`` has no
``--workers``).

Each measure runs in its own process with a timeout: a failure prints "error" (or
"timeout") in its cells and the table goes on. Scenes are made once into
``$TMPDIR/puppet-bench-scale`` and reused between runs.

    .venv/bin/python benchmarks/bench_scale.py [--sizes 2k,8k,...] [--quick] [--runs 2]

``--open SCENE [--compare DIR] [--runs N]`` times only the load + first render of one scene,
cold and cached, N rounds, and with ``--compare`` the puppet package in DIR in the same
rounds (PYTHONPATH=DIR), alternated: a before/after under the same load.
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

import numpy as np
from PIL import Image
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from benchmarks.bench_drag import garment_4k, load_floor  # noqa: E402
from benchmarks.common import middle_pin, pose_gap, psd4k_scene  # noqa: E402

import puppet  # noqa: E402

TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
SIZES = ["2k", "8k", "32k", "128k", "psd4k", "garment", "islands"]
#: T-rex copies: label -> (art scale, max_area of every layer); measured 2.2k, 8.2k, 31.7k vertices at scale 1
#: and 135.8k at scale 2 with 1.9 px²
TREX_MESH = {"2k": (1, 30.0), "8k": (1, 7.5), "32k": (1, 1.9), "128k": (2, 2.0)}
#: the islands: transparent lines every TILE px, GAP px wide, over the 4000x4000 garment
TILE, GAP = 250, 24
CACHE = ".puppet-cache"
ERROR_POINTS = 5


# -- the scenes ----------------------------------------------------------------------------------
def trex_dense(folder: str, label: str) -> str:
    """A copy of the T-rex with every layer meshed at ``TREX_MESH[label]`` (art scaled)."""
    scale, area = TREX_MESH[label]
    path = os.path.join(folder, f"trex-{label}.json")
    with open(TREX) as f:
        data = json.load(f)
    for L in data["layers"]:
        src = os.path.normpath(os.path.join(os.path.dirname(TREX), L["image"]))
        if scale != 1:
            im = Image.open(src)
            dst = os.path.join(folder, f"x{scale}-{os.path.basename(src)}")
            im.resize((im.width * scale, im.height * scale), Image.LANCZOS).save(dst)
            src = dst
        L["image"], L["mesh"] = src, {"max_area": area}
    if scale != 1:
        data = scaled(data, scale)
    with open(path, "w") as f:
        json.dump(data, f)
    return path


def scaled(data: dict, s: int) -> dict:
    """The T-rex scene's coordinates (canvas, pins, link segments, pose targets) times ``s``."""
    def xy(p):
        return [v * s for v in p]
    data["canvas"] = xy(data["canvas"])
    for p in data["pins"]:
        p["at"] = xy(p["at"])
    for link in data["links"]:
        link["segments"] = [[xy(q) for q in seg] for seg in link["segments"]]
    for pose in data["poses"].values():
        for name, t in pose.items():
            pose[name] = xy(t) if isinstance(t, list) else dict(t, to=xy(t["to"]))
    return data


def garment_islands(folder: str) -> str:
    """The 4000x4000 garment photo cut into ~165 islands, through ``puppet init --alpha --pins auto``."""
    # lazy: a measuring process must not have imported the scene makers before it times load_scene
    from puppet.scene.make.picture import init_scene

    emoji = os.path.join(ROOT, "assets", "noto-emoji", "emoji_u1f455.png")  # bench_drag.garment_4k's photo
    rgba = np.array(Image.open(emoji).convert("RGBA").resize((4000, 4000), Image.BICUBIC))
    for k in range(0, rgba.shape[0], TILE):
        rgba[k:k + GAP, :, 3] = 0
        rgba[:, k:k + GAP, 3] = 0
    image = os.path.join(folder, "islands.png")
    Image.fromarray(rgba).save(image)
    path = os.path.join(folder, "islands.json")
    init_scene(image, path, rule="alpha", pins="auto")
    return path


def make_scene(row: str, base: str) -> str:
    """The scene of ``row``, made once into ``base/row/`` (a finished file is reused)."""
    folder = os.path.join(base, row)
    done = os.path.join(folder, "scene.txt")
    if os.path.exists(done):
        with open(done) as f:
            return f.read()
    os.makedirs(folder, exist_ok=True)
    if row in TREX_MESH:
        path = trex_dense(folder, row)
    elif row == "psd4k":
        path = psd4k_scene(folder)
    elif row == "garment":
        path = garment_4k(folder)
    else:
        path = garment_islands(folder)
    with open(done, "w") as f:
        f.write(path)
    return path


# -- measures (each in a child process) ------------------------------------------------------------
def drag_path(start: np.ndarray, steps: int, radius: float) -> np.ndarray:
    """``steps`` points over three quarters of a circle that passes through ``start``
    (``radius`` < 0: the circle on the left of ``start``, turning the other way)."""
    t = np.linspace(0, 1.5 * np.pi, steps + 1)[1:]
    return np.stack([start[0] + radius * (1 - np.cos(t)), start[1] - abs(radius) * np.sin(t)], axis=1)


def preview_error(scene, pin: str, path: np.ndarray) -> dict:
    """Distances (px) between the preview and the exact pose at ``ERROR_POINTS`` points of
    ``path`` over the vertices of the dragged pin's group; the release (with its full-size
    frame drawn) at the path's end timed."""
    marks = np.linspace(0, len(path) - 1, ERROR_POINTS).round().astype(int)
    d, previews = scene.drag(pin), {}
    for k, xy in enumerate(path):
        layers = d.move_layers(xy)
        if k in marks:
            previews[k] = layers
    t0 = time.perf_counter()
    d.release()
    release_draw = time.perf_counter() - t0
    scene.undo()
    dist = []
    for k in marks:
        d = scene.drag(pin)
        d.move_layers(path[k])
        dist.append(pose_gap(previews[k], d.release_layers(), pin))
        scene.undo()
    dist = np.concatenate(dist)
    return {"release_draw": release_draw, "err_med": float(np.median(dist)),
            "err_p95": float(np.percentile(dist, 95)), "err_max": float(dist.max())}


def islands(F: np.ndarray, n: int) -> int:
    """The number of connected pieces of a mesh of ``n`` vertices and triangles ``F``."""
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]]])
    return connected_components(coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)), directed=False)[0]


def measure_drag(path: str, steps: int) -> dict:
    """Vertices, groups, move times, release times and the preview error of one scene."""
    scene = puppet.load_scene(path)
    groups = scene.built.groups
    out = {"vertices": sum(len(g.mesh.V) for g in groups), "groups": len(groups),
           "islands": sum(islands(g.mesh.F, len(g.mesh.V)) for g in groups)}
    scene.render(size=(640, 640))  # textures and the solver's parts built before timing
    pin, start = middle_pin(path)
    radius = 0.04 * max(scene.canvas)
    route = drag_path(start, steps, radius)
    d = scene.drag(pin)
    d.move(start)  # the first frame (textures at preview size): not counted
    moves, cpu = [], []
    for xy in route:
        t0, c0 = time.perf_counter(), time.process_time()
        d.move(xy)
        moves.append(1000 * (time.perf_counter() - t0))
        cpu.append(1000 * (time.process_time() - c0))
    t0, c0 = time.perf_counter(), time.process_time()
    d.release_layers()
    out.update(release=time.perf_counter() - t0, release_cpu=time.process_time() - c0)
    scene.undo()
    out.update(pin=pin, move_med=float(np.median(moves)), move_p95=float(np.percentile(moves, 95)),
               move_cpu=float(np.median(cpu)))
    out.update(preview_error(scene, pin, drag_path(start, steps, -radius)))  # not a pose solved before
    scene.close()
    return out


def measure_open(path: str) -> dict:
    """Load + first render (full size) of a scene, timed in this (new) process (puppet
    already imported)."""
    t0, c0 = time.perf_counter(), time.process_time()
    scene = puppet.load_scene(path)
    t1 = time.perf_counter()
    scene.render()
    t2 = time.perf_counter()
    scene.close()
    return {"load": t1 - t0, "render": t2 - t1, "open": t2 - t0, "open_cpu": time.process_time() - c0}


def child(work: list[str], args, package: str | None = None) -> dict:
    """Run this script's ``--worker`` ``work`` (kind, argument); its JSON result, or {"error": why}.
    ``package``: a folder holding another puppet package, imported instead of this checkout's."""
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", *work, "--steps", str(args.steps), "--folder",
           args.folder]
    env = None if package is None else {**os.environ, "PYTHONPATH": os.path.abspath(package)}
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout, cwd=ROOT, env=env)
    except subprocess.TimeoutExpired:
        return {"error": "timeout"}
    if p.returncode != 0 or not p.stdout.strip():
        sys.stderr.write(f"bench_scale: {work} failed: {p.stderr.strip()[-800:]}\n")
        return {"error": "error"}
    return json.loads(p.stdout.strip().splitlines()[-1])


def worker(kind: str, arg: str, steps: int, base: str) -> None:
    if kind == "prepare":
        print(json.dumps({"path": make_scene(arg, base)}))
    elif kind == "drag":
        print(json.dumps(measure_drag(arg, steps)))
    else:
        print(json.dumps(measure_open(arg)))


# -- the table --------------------------------------------------------------------------------------
def open_cold_cached(path: str, args, package: str | None = None) -> tuple[dict, dict]:
    """Load + first render with the scene's cache folder removed, then again (cached) when
    a cache folder appeared; ({"open": s} or {"error": why}, the same or {"error": "n/a"})."""
    cache = os.path.join(os.path.dirname(path), CACHE)
    shutil.rmtree(cache, ignore_errors=True)
    cold = child(["open", path], args, package)
    if not os.path.isdir(cache):
        return cold, {"error": "n/a"}
    return cold, child(["open", path], args, package)


def open_table(path: str, args) -> None:
    """``--open``: load + first render of one scene, cold and cached, ``--runs`` rounds; with
    ``--compare DIR`` the puppet package in DIR is timed in the same rounds, alternated."""
    codes = [("this", None)] + ([(f"compared ({args.compare})", args.compare)] if args.compare else [])
    print(f"\nload + first render of {path}; {header()}\n"
          "| round | code | cold s (CPU s) | cached s (CPU s) | load average |\n|---|---|---|---|---|", flush=True)
    for run in range(args.runs):
        for name, package in codes:
            cold, cached = open_cold_cached(path, args, package)
            cells = [f"{cell(r, 'open', '.2f')} ({cell(r, 'open_cpu', '.2f')})" for r in (cold, cached)]
            print(f"| {run + 1} | {name} | {cells[0]} | {cells[1]} | {os.getloadavg()[0]:.2f} |", flush=True)


def row(name: str, args) -> dict:
    made = child(["prepare", name], args)
    if "error" in made:
        return {"name": name, "error": made["error"]}
    r = {"name": name, **child(["drag", made["path"]], args)}
    r["cold"], r["cached"] = open_cold_cached(made["path"], args)
    return r


def cell(r: dict, key: str, spec: str, scale: float = 1.0) -> str:
    """``r[key]`` formatted, or the row's error word."""
    if key in r:
        return format(r[key] * scale if scale != 1 else r[key], spec)
    return r.get("error", "-")


def print_header() -> None:
    print("| scene | vertices | groups (islands) | move med ms (CPU) | move p95 ms | release_layers ms (CPU) | "
          "release + draw ms | preview error px (med / p95 / max) | load + first render s (CPU): cold | cached |")
    print("|---|---|---|---|---|---|---|---|---|---|", flush=True)


def print_row(r: dict) -> None:
    err = " / ".join(cell(r, k, ".1f") for k in ("err_med", "err_p95", "err_max"))
    cold, cached = (f"{cell(r.get(k, {}), 'open', '.2f')} ({cell(r.get(k, {}), 'open_cpu', '.2f')})"
                    if "open" in r.get(k, {}) else cell(r.get(k, {}), "open", ".2f") for k in ("cold", "cached"))
    print(f"| {r['name']} | {cell(r, 'vertices', 'd')} | {cell(r, 'groups', 'd')} ({cell(r, 'islands', 'd')}) | "
          f"{cell(r, 'move_med', '.0f')} ({cell(r, 'move_cpu', '.0f')}) | {cell(r, 'move_p95', '.0f')} | "
          f"{cell(r, 'release', '.0f', 1000)} ({cell(r, 'release_cpu', '.0f', 1000)}) | "
          f"{cell(r, 'release_draw', '.0f', 1000)} | {err} | {cold} | {cached} |", flush=True)


# -- export -------------------------------------------------------------------------------------------
def has_workers() -> bool:
    """Whether ``puppet animate`` takes ``--workers`` (part of issue 31)."""
    p = subprocess.run([sys.executable, "-m", "puppet", "animate", "--help"], capture_output=True, text=True,
                       cwd=ROOT, timeout=120)
    return "--workers" in p.stdout


def frames_in(path: str) -> int:
    import av  # lazy: only the export measure reads a video

    with av.open(path) as f:
        return sum(1 for _ in f.demux(video=0) if _.size)


def animate(video: str, size: str, until: str, workers: int | None, timeout: float) -> tuple[int, float]:
    """Frames written and wall seconds of ``puppet animate`` of the T-rex to ``video``
    (``workers``: its ``--workers``, None: leave the flag out)."""
    cmd = [sys.executable, "-m", "puppet", "animate", TREX, "-o", video, "--size", size, "--fps", "60",
           "--to", until] + ([] if workers is None else ["--workers", str(workers)])
    t0 = time.perf_counter()
    subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT, check=True)
    return frames_in(video), time.perf_counter() - t0


def export_rates(quick: bool, timeout: float) -> list[tuple[str, str, str]]:
    """(workers, frames/s over the command's wall time, steady frames/s) of ``puppet animate``
    of the T-rex to MP4, for workers 1, 2 and all cores. Steady: the frames past the first
    two over the time past a 2-frame export's (start-up, loading, the encoder's set-up)."""
    size, until = ("320x240", "2") if quick else ("1280x720", "8")
    counts = [None]
    if has_workers():
        counts = [1, 2] + ([os.cpu_count()] if (os.cpu_count() or 1) > 2 else [])
    out, first = [], None
    with tempfile.TemporaryDirectory() as tmp:
        for n in counts:
            video, label = os.path.join(tmp, f"w{n}.mp4"), str(n or "default (no --workers: n/a)")
            try:
                frames, wall = animate(video, size, until, n, timeout)
                two, start = animate(video, size, f"{1 / 60:.4f}", n, timeout)
                steady = (frames - two) / max(wall - start, 1e-9)
                first = first or steady
                rate = f"{frames / wall:.1f} ({frames} frames, {wall:.1f} s)"
                out.append((label, rate, f"{steady:.1f} ({steady / first:.2f}x)"))
            except subprocess.TimeoutExpired:
                out.append((label, "timeout", "timeout"))
            except (subprocess.CalledProcessError, OSError, ValueError) as e:
                sys.stderr.write(f"bench_scale: export with {n} workers: {e}\n")
                out.append((label, "error", "error"))
    return out


def header() -> str:
    from threadpoolctl import threadpool_info

    blas = ", ".join(f"{i['internal_api']}:{i['num_threads']}" for i in threadpool_info())
    return (f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}, {os.cpu_count()} cores, BLAS threads "
            f"{blas or 'none loaded'}, numpy floor {load_floor():.1f} ms (quiet: ~1.3 ms)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(SIZES), help=f"rows, any of {','.join(SIZES)}")
    ap.add_argument("--quick", action="store_true", help="rows 2k,8k, 12 drag steps, a short small export")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--steps", type=int, default=40, help="preview moves along the drag path")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds for one measure of one scene")
    ap.add_argument("--no-export", action="store_true", help="leave out the export table")
    ap.add_argument("--folder", default=os.path.join(tempfile.gettempdir(), "puppet-bench-scale"),
                    help="where the scenes are made once and reused")
    ap.add_argument("--open", metavar="SCENE", help="only the load + first render of SCENE, cold and cached")
    ap.add_argument("--compare", metavar="DIR", help="with --open: also the puppet package in DIR (e.g. "
                    "`git archive OLD puppet | tar -x -C DIR`), alternated in each round")
    ap.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(*args.worker, args.steps, args.folder)
        return 0
    if args.open:
        open_table(os.path.abspath(args.open), args)
        return 0
    if args.quick:
        args.sizes, args.steps = ("2k,8k" if args.sizes == ",".join(SIZES) else args.sizes), 12
    names = args.sizes.split(",")
    bad = [n for n in names if n not in SIZES]
    if bad:
        ap.error(f"unknown size {bad[0]!r} (any of {','.join(SIZES)})")
    for run in range(args.runs):
        print(f"\nrun {run + 1}: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {header()}", flush=True)
        print_header()
        for n in names:
            print_row(row(n, args))
        if not args.no_export:
            print("\n| export: T-rex to MP4, workers | frames/s (frames, wall s) | steady frames/s (against 1) |"
                  "\n|---|---|---|")
            for n, rate, steady in export_rates(args.quick, args.timeout):
                print(f"| {n} | {rate} | {steady} |", flush=True)
        print(f"load average after run {run + 1}: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
