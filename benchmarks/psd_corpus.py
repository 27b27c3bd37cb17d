"""The layered import over a folder of real PSD/PSB files (e.g. psd-tools' tests/psd_files).

Each file is imported by ``puppet init FILE -o SCENE.json`` in its own process with a
time limit. A file passes when it imports (exit 0) or fails with one line
``puppet: error: FILE: ...`` (exit 2), within the limit, with nothing else on stderr
than ``puppet: note:`` lines, and when it holds several
visible pixel layers (counted independently with psd-tools: visible leaf layers with
pixels, not clipped, not adjustments, inside visible groups) it imports as several
layers. Prints one row per file that does not pass, then the counts.

    .venv/bin/python benchmarks/psd_corpus.py FOLDER [--timeout 60] [--list]

The psd-tools corpus: ``git show`` the files of tests/psd_files out of a clone of
github.com/psd-tools/psd-tools into FOLDER (MIT, not bundled here).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PUPPET = [sys.executable, "-m", "puppet"]


def visible_pixel_layers(path: str) -> int | None:
    """Visible pixel-bearing leaf layers, as psd-tools sees them (None: it cannot read the file)."""
    from psd_tools import PSDImage
    from psd_tools.api.layers import AdjustmentLayer

    try:
        psd = PSDImage.open(path)
        n = 0
        for layer in psd.descendants():
            if layer.is_group() or isinstance(layer, AdjustmentLayer) or layer.clipping or not layer.is_visible():
                continue
            x0, y0, x1, y1 = layer.bbox
            n += x1 > x0 and y1 > y0 and layer.has_pixels()
        return n
    except Exception:
        return None


def run(path: str, timeout: float, out: str) -> dict:
    t0 = time.perf_counter()
    try:
        p = subprocess.run(PUPPET + ["init", path, "-o", out], capture_output=True, text=True, timeout=timeout,
                           cwd=ROOT)
    except subprocess.TimeoutExpired:
        return {"file": path, "status": "hang", "seconds": timeout}
    row = {"file": path, "rc": p.returncode, "seconds": round(time.perf_counter() - t0, 2)}
    err_lines = [line for line in p.stderr.splitlines() if line and not line.startswith("puppet: note:")]
    if p.returncode == 0 and err_lines:  # imported, but something else reached the terminal
        row["status"] = "chatter"
        row["error"] = err_lines[0]
    elif p.returncode == 0:
        row["layers"] = len(json.load(open(out))["layers"])
        row["status"] = "imported"
        row["notes"] = sum(line.startswith("puppet: note:") for line in p.stderr.splitlines())
    elif p.returncode == 2 and len(err_lines) == 1 and err_lines[0].startswith("puppet: error: "):
        row["status"] = "refused"
        row["error"] = err_lines[0][len("puppet: error: "):]
    else:
        row["status"] = "crash"
        row["error"] = (p.stderr.strip().splitlines() or ["(nothing)"])[-1]
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder")
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--list", action="store_true", help="print every file's row")
    args = ap.parse_args()
    files = sorted(os.path.join(d, f) for d, _, fs in os.walk(args.folder) for f in fs
                   if f.lower().endswith((".psd", ".psb")))
    counts: dict[str, int] = {}
    several = flat = 0
    with tempfile.TemporaryDirectory() as tmp:
        for i, path in enumerate(files):
            row = run(path, args.timeout, os.path.join(tmp, f"s{i}.json"))
            row["visible"] = expected = visible_pixel_layers(path)
            counts[row["status"]] = counts.get(row["status"], 0) + 1
            if expected is not None and expected >= 2:
                several += 1
                row["flattened"] = row["status"] != "imported" or row["layers"] < 2
                flat += row["flattened"]
            if args.list or row["status"] in ("hang", "crash", "chatter") or row.get("flattened"):
                print(json.dumps(row), flush=True)
    print(f"{len(files)} files: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    print(f"{several} hold several visible pixel layers; {several - flat} of them import as several layers")
    bad = counts.get("hang", 0) + counts.get("crash", 0) + counts.get("chatter", 0) + flat
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
