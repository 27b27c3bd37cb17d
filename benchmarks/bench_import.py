"""Layered import speed: a 4000x4000 PSD with 20 layers through ``puppet init``.

The PSD is made once (psd-tools' writer, RLE): 20 pixel layers, each a soft-edged
ellipse of about 1000x1400 px with a colour gradient and a painted texture, spread
over the canvas, two in a group. Prints one row per run: the file's size, the time
to read the layers (``read_layered``, in process), and the wall time of the whole
command (``puppet init ART.psd -o SCENE.json`` as a new process: start-up, reading,
PNG encoding, validation, writing), and of ``--pins auto --links auto`` (which also
meshes every layer to check the pins and link segments).

    .venv/bin/python benchmarks/bench_import.py [--runs 2] [--size 4000] [--layers 20]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def psd_parts(size: int, layers: int):
    """(index, RGBA (h, w, 4) uint8, x, y) of each part :func:`make_psd` draws (seeded)."""
    rng = np.random.default_rng(1)
    for i in range(layers):
        w, h = int(size * rng.uniform(0.2, 0.3)), int(size * rng.uniform(0.3, 0.4))
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        r = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
        a = np.zeros((h, w, 4), np.uint8)
        base = rng.integers(40, 215, 3)
        for c in range(3):
            a[..., c] = np.clip(base[c] + 40 * (yy / h - 0.5) + 8 * np.sin(xx / 9.0 + c), 0, 255)
        a[..., 3] = np.clip((1 - r) * 60, 0, 1) * 255
        x, y = int(rng.uniform(0, size - w)), int(rng.uniform(0, size - h))
        yield i, a, x, y


def make_psd(path: str, size: int, layers: int) -> None:
    from PIL import Image
    from psd_tools import PSDImage

    psd = PSDImage.new("RGBA", (size, size), color=(0, 0, 0, 0))
    group = None
    for i, a, x, y in psd_parts(size, layers):
        parent = psd
        if i in (8, 9):
            group = group or psd.create_group(name="legs")
            parent = group
        parent.create_pixel_layer(Image.fromarray(a), name=f"part{i}", left=x, top=y)
    psd.save(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--size", type=int, default=4000)
    ap.add_argument("--layers", type=int, default=20)
    args = ap.parse_args()
    from threadpoolctl import threadpool_info

    from puppet.imaging.layered import read_layered

    blas = ",".join(f"{i['internal_api']}:{i['num_threads']}" for i in threadpool_info())
    print(f"load {os.getloadavg()[0]:.1f}, cpus {os.cpu_count()}, threads {blas}")
    with tempfile.TemporaryDirectory() as tmp:
        art = os.path.join(tmp, "big.psd")
        t0 = time.perf_counter()
        make_psd(art, args.size, args.layers)
        print(f"made {art}: {os.path.getsize(art) / 1e6:.1f} MB in {time.perf_counter() - t0:.1f} s")
        print("| run | document | layers | file MB | read_layered s | puppet init s | --pins auto --links auto s |")
        print("|---|---|---|---|---|---|---|")
        for run in range(args.runs):
            t0 = time.perf_counter()
            got = read_layered(art)
            read = time.perf_counter() - t0
            scene = os.path.join(tmp, f"s{run}.json")
            walls = []
            for flags in ([], ["--pins", "auto", "--links", "auto"]):
                t0 = time.perf_counter()
                p = subprocess.run([sys.executable, "-m", "puppet", "init", art, "-o", scene, *flags],
                                   capture_output=True, text=True, cwd=ROOT)
                walls.append(time.perf_counter() - t0)
                if p.returncode != 0:
                    print(p.stderr)
                    return 1
            print(f"| {run + 1} | {args.size}x{args.size} | {len(got.layers)} | {os.path.getsize(art) / 1e6:.1f} | "
                  f"{read:.2f} | {walls[0]:.2f} | {walls[1]:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
