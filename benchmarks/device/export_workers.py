"""`puppet animate` of the T-rex cycled to N frames, 1280x720 MP4, against --workers: wall time and
frames in the file. Arguments FRAMES:WORKERS, e.g. `1000:16 240:1`."""
import json, os, subprocess, sys, time
ROOT = os.getcwd()
sys.path.insert(0, ROOT)
from benchmarks.bench_animate_memory import long_animation
import av

def scene(frames):
    src = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
    data = long_animation(json.load(open(src)), frames, 24.0)
    path = os.path.join(ROOT, "assets", "scenes", f"_dev{frames}.json")  # beside the T-rex: its images by relative path
    json.dump(data, open(path, "w"))
    return path

def count(path):
    with av.open(path) as f:
        return sum(1 for p in f.demux(video=0) if p.size)

runs = [(int(a), int(b)) for a, b in (x.split(":") for x in sys.argv[1:])]
for frames, n in runs:
    path = scene(frames)
    out = f"/tmp/w{n}-{frames}.mp4"
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "puppet", "animate", path, "-o", out, "--size", "1280x720",
                        "--workers", str(n)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    got = count(out) if p.returncode == 0 else 0
    os.remove(path)
    print(f"export workers={n:2d} frames={got:4d}/{frames} wall={wall:6.2f} s  {got / wall:6.1f} frames/s  "
          f"load={os.getloadavg()[0]:.1f} rc={p.returncode} {p.stderr.strip()[-300:]}", flush=True)
