"""GrabCut's bounded working size (issue 20): time and peak memory of
:func:`puppet.imaging.masks.grabcut_mask` on synthetic pictures of 1, 16 and 64 megapixels
(an ellipse on a lightly striped ground, the rectangle around it), each in a fresh process
so the peak resident size is its own. Also the pixels that differ from the true ellipse.
Prints a table.

    .venv/bin/python benchmarks/bench_grabcut.py
"""
from __future__ import annotations

import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ONE = """
import json, resource, sys, time
import numpy as np
from puppet.imaging.masks import grabcut_mask
side = int(sys.argv[1])
img = np.full((side, side, 4), 230, np.uint8)
yy, xx = np.ogrid[:side, :side]
c = side / 2
blob = (yy - c) ** 2 / (0.37 * side) ** 2 + (xx - c) ** 2 / (0.25 * side) ** 2 < 1
img[blob, :3] = 40
img[..., 0] += (np.arange(side) % 7).astype(np.uint8)[None, :]
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter()
m = grabcut_mask(img, [side // 8, side // 16, side * 3 // 4, side * 7 // 8])
dt = time.perf_counter() - t
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"s": dt, "peak_mb": peak / 1024, "before_mb": base / 1024, "wrong": int((m ^ blob).sum()),
                  "area": int(blob.sum())}))
"""


def main():
    print(f"load: {os.getloadavg()[0]:.2f}")
    print(f"{'picture':>12s} {'MP':>5s} {'s':>7s} {'peak MB':>8s} {'input MB':>8s} {'wrong px':>9s} {'of area':>8s}")
    for side in (1024, 4096, 8192):
        out = subprocess.run([sys.executable, "-c", ONE, str(side)], capture_output=True, text=True,
                             env=dict(os.environ, PYTHONPATH=os.path.join(HERE, "..")), timeout=900)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"{side:>5d}x{side:<6d} {side * side / 1e6:5.1f} {r['s']:7.2f} {r['peak_mb']:8.0f} {r['before_mb']:8.0f} "
              f"{r['wrong']:9d} {100 * r['wrong'] / r['area']:7.3f}%")


if __name__ == "__main__":
    main()
