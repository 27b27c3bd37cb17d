"""The dressing room's page: how soon a fresh headless Chromium has drawn the first outfit.

Run: ``python benchmarks/bench_room_page.py [--runs 5]`` from the repository root (needs
Debian's ``chromium``). Writes the room of the bundled mannequin with the t-shirt, jeans
and shoes (``assets/scenes/room``) as one file, opens it at ``#outfit=t-shirt,jeans,shoes``
in a new browser each run (its own profile, 1040 x 780) and prints, per run, the page's
``performance.now()`` when it had drawn the outfit (``data-first-draw-ms``, from the
navigation's start) and its DOMContentLoaded; beside them the floor: an empty page of the
same size whose script says it ran. The load average is printed: the machine is shared.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOM = os.path.join(ROOT, "assets", "scenes", "room")
REPORT = ("<script>(async () => { while (document.body.dataset.ready !== '1') await new Promise((r) => "
          "setTimeout(r, 5)); const t = performance.getEntriesByType('navigation')[0]; console.log('FIRSTDRAW ' + "
          "document.body.dataset.firstDrawMs + ' ' + t.domContentLoadedEventEnd.toFixed(1)); })();</script></body>")
FLOOR = ("<!doctype html><html><head><meta charset='utf-8'></head><body><canvas width='700' height='720'></canvas>"
         "<script>document.body.dataset.firstDrawMs = performance.now().toFixed(1); "
         "document.body.dataset.ready = '1';</script></body></html>")


def first_draw(chromium: str, page: str, hash_: str, tmp: str) -> tuple[float, float] | None:
    profile = tempfile.mkdtemp(dir=tmp)
    try:
        proc = subprocess.Popen([chromium, "--headless=new", "--no-sandbox", "--enable-logging=stderr", "--v=0",
                                 "--window-size=1040,780", f"--user-data-dir={profile}", f"file://{page}#{hash_}"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            for line in proc.stderr:
                m = re.search(r"FIRSTDRAW ([\d.]+) ([\d.]+)", line)
                if m:
                    return float(m[1]), float(m[2])
        finally:
            proc.kill()
            proc.wait()
    finally:
        shutil.rmtree(profile, ignore_errors=True)
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        sys.exit("chromium is not installed")
    import puppet
    from puppet.cli import main as cli

    with tempfile.TemporaryDirectory(prefix="bench-room-page-") as tmp:
        for name in ("mannequin", "t-shirt", "jeans", "shoes"):
            puppet.load_scene(os.path.join(ROOM, name + ".json")).save(os.path.join(tmp, name + ".json"), copy=True)
        room = os.path.join(tmp, "room.html")
        assert cli(["dressroom", *(os.path.join(tmp, n + ".json") for n in ("mannequin", "t-shirt", "jeans",
                                                                              "shoes")), "-o", room]) == 0
        with open(room, encoding="utf-8") as f:
            text = f.read()
        page = os.path.join(tmp, "room-timed.html")
        with open(page, "w", encoding="utf-8") as f:
            f.write(text.replace("</body>", REPORT))
        floor = os.path.join(tmp, "floor.html")
        with open(floor, "w", encoding="utf-8") as f:
            f.write(FLOOR.replace("</body>", REPORT))
        print(f"room of 3 garments: {os.path.getsize(room) / 1024:.0f} KB; load before {os.getloadavg()[0]:.2f}")
        print("| run | first outfit drawn, ms | its DOMContentLoaded, ms | floor: an empty page's script ran, ms |")
        print("|---|---|---|---|")
        rows = []
        for r in range(args.runs):
            a = first_draw(chromium, page, "outfit=t-shirt,jeans,shoes", tmp)
            b = first_draw(chromium, floor, "", tmp)
            rows.append((a[0], a[1], b[0]))
            print(f"| {r} | {a[0]:.0f} | {a[1]:.0f} | {b[0]:.0f} |")
        v = np.array(rows)
        print(f"| median | {np.median(v[:, 0]):.0f} | {np.median(v[:, 1]):.0f} | {np.median(v[:, 2]):.0f} |")
        print(f"load after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
