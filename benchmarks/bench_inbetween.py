"""In-betweens: straight-line pin paths ("linear") against as-rigid-as-possible shape
interpolation ("rigid") on an arm swinging 180 degrees and on the bundled scenes.

Usage: python benchmarks/bench_inbetween.py [--fps 24] [--figure docs/img/inbetween.png]

For every frame between two keys it measures, over all triangles of all layers:
  min area   smallest deformed/rest triangle area ratio (1 = kept, 0 = collapsed, < 0 flipped)
  1% area    the 1st percentile of that ratio in the worst frame
  flipped    triangles turned over (signed area changed sign), worst frame
  overlap    pixels where a layer covers itself twice (folds over itself), worst frame
  stretch    largest singular value of a triangle's deformation gradient (1 = rigid)
  squash     smallest singular value (1 = rigid, 0 = collapsed)
  arm        hand-to-shoulder distance / rest distance, smallest over the frames
  ms/frame   time per in-between frame once the key meshes are solved (median)
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import puppet  # noqa: E402
from puppet.deform.interp import jacobians  # noqa: E402

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def arm_scene(folder: str, keys: str = "two", joined: bool = False) -> str:
    """A body and, in front of it, an arm hanging at its side (two layers of one picture;
    ``joined``: one layer, the arm joined to the body by a shoulder); keys swing the arm
    180 degrees about the shoulder, up over the head: ``two`` keys (down, up) or
    ``three`` (down, out, up)."""
    W, H = 440, 640
    im = np.zeros((H, W, 4), np.uint8)
    im[320:600, 100:200] = (70, 110, 200, 255)  # body
    im[320:540, 208:240] = (200, 120, 90, 255)  # arm
    im[470:540, 208:240] = (230, 190, 120, 255)  # hand
    if joined:
        im[320:352, 200:208] = (200, 120, 90, 255)  # shoulder
    Image.fromarray(im).save(os.path.join(folder, "arm-joined.png" if joined else "arm.png"))
    sx, sy = 224.0, 336.0
    arm = {"elbow": 97.0, "hand": 189.0}  # distances from the shoulder, down the arm at rest
    poses = {"up": {k: [sx, sy - d] for k, d in arm.items()}, "out": {k: [sx + d, sy] for k, d in arm.items()}}
    seq = ["rest", "up"] if keys == "two" else ["rest", "out", "up"]
    scene = {"puppet": 1, "canvas": [W, H], "background": [255, 255, 255, 255],
             "source": "arm-joined.png" if joined else "arm.png",
             "layers": [{"name": "body", "mask": {"rect": [96, 316, 108, 288]}, "mesh": {"max_area": 40}},
                        {"name": "arm", "mask": {"rect": [204, 316, 40, 228]}, "mesh": {"max_area": 40}}],
             "pins": [{"name": "hip", "layer": "body", "at": [150, 560]},
                      {"name": "chest", "layer": "body", "at": [150, 380]},
                      {"name": "shoulder", "layer": "arm", "at": [sx, sy]}]
             + [{"name": k, "layer": "arm", "at": [sx, sy + d]} for k, d in arm.items()],
             "poses": poses,
             "animation": {"fps": 24, "keys": [{"time": float(i), "pose": p} for i, p in enumerate(seq)]}}
    if joined:
        scene["layers"] = [{"name": "figure", "mesh": {"max_area": 40}}]
        for pin in scene["pins"]:
            pin["layer"] = "figure"
    path = os.path.join(folder, f"arm-{keys}{'-joined' if joined else ''}.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    return path


def overlap_pixels(U: np.ndarray, F: np.ndarray) -> int:
    """Pixel centres covered by two or more triangles of one mesh: where a layer folds
    over itself (e.g. an arm collapsing at the elbow), which flipped-triangle counts miss.
    Every (triangle, pixel of its bounding box) pair is tested at once."""
    P = U - np.floor(U.min(axis=0))
    W = int(np.ceil(P[:, 0].max())) + 2
    T = P[F]  # (m, 3, 2)
    lo = np.floor(T.min(axis=1)).astype(np.int64)
    n = (np.ceil(T.max(axis=1)).astype(np.int64) - lo)  # (m, 2) bounding box size
    cnt = n[:, 0] * n[:, 1]
    tri = np.repeat(np.arange(len(F)), cnt)
    k = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    px = lo[tri, 0] + k % n[tri, 0]
    py = lo[tri, 1] + k // n[tri, 0]
    X, Y = px + 0.5, py + 0.5
    a, b, c = T[tri, 0], T[tri, 1], T[tri, 2]
    s = np.sign((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    inside = np.ones(len(tri), bool)
    for p, q in ((a, b), (b, c), (c, a)):
        inside &= s * ((q[:, 0] - p[:, 0]) * (Y - p[:, 1]) - (q[:, 1] - p[:, 1]) * (X - p[:, 0])) > 0
    hits = np.bincount(py[inside] * W + px[inside])
    return int((hits >= 2).sum())


def frame_metrics(layers) -> dict:
    """Area ratio, flipped triangles, self-overlap and singular values of one frame."""
    amin, p1, folded, smax, smin, over = np.inf, np.inf, 0, 0.0, np.inf, 0
    for r in layers:
        F = r.triangles
        if not len(F):
            continue
        J = jacobians(r.rest, F, r.deformed)
        det = np.linalg.det(J)
        s = np.linalg.svd(J, compute_uv=False)
        amin, p1 = min(amin, float(det.min())), min(p1, float(np.percentile(det, 1)))
        folded += int((det <= 0).sum())
        smax = max(smax, float(s[:, 0].max()))
        smin = min(smin, float(s[:, 1].min()))
        over += overlap_pixels(r.deformed, F)
    return {"amin": amin, "p1": p1, "folded": folded, "smax": smax, "smin": smin, "over": over}


def measure(path: str, mode: str, fps: float, t0: float | None = None, t1: float | None = None,
            arm: tuple[str, str] | None = None) -> dict:
    """Metrics over the frames strictly between keys of ``path`` from ``t0`` to ``t1``."""
    sc = puppet.load_scene(path)
    sc.set_inbetween(mode)
    keys = sc.key_times()
    t0 = keys[0] if t0 is None else t0
    t1 = keys[-1] if t1 is None else t1
    times = [t for t in np.arange(t0, t1 + 1e-9, 1 / fps) if min(abs(t - k) for k in keys) > 1e-9]
    for k in keys:  # the key meshes, solved once (not timed)
        sc.layers(time=k)
    out = {"amin": np.inf, "p1": np.inf, "folded": 0, "smax": 0.0, "smin": np.inf, "over": 0, "arm": np.inf,
           "ms": []}
    rest = {r.name: r for r in sc.layers("rest")}
    for t in times:
        start = time.perf_counter()
        layers = sc.layers(time=float(t))
        out["ms"].append(1000 * (time.perf_counter() - start))
        m = frame_metrics(layers)
        for k in ("amin", "p1", "smin"):
            out[k] = min(out[k], m[k])
        for k in ("folded", "smax", "over"):
            out[k] = max(out[k], m[k])
        if arm:
            for r in layers:
                if arm[0] in r.pins and arm[1] in r.pins:
                    d = np.linalg.norm(r.deformed[r.pins[arm[1]]] - r.deformed[r.pins[arm[0]]])
                    d0 = np.linalg.norm(rest[r.name].deformed[r.pins[arm[1]]] - rest[r.name].deformed[r.pins[arm[0]]])
                    out["arm"] = min(out["arm"], d / d0)
    out["frames"] = len(times)
    out["ms"] = float(np.median(out["ms"])) if out["ms"] else float("nan")
    return out


def figure(path: str, out: str, times, *, size=None, crop=None) -> None:
    """A PNG strip: row 1 linear, row 2 rigid, one column per time (puppet's renderer)."""
    rows = []
    for mode in ("linear", "rigid"):
        sc = puppet.load_scene(path)
        sc.set_inbetween(mode)
        frames = [sc.render(time=float(t), size=size) for t in times]
        sc.close()
        if crop is not None:
            x0, y0, x1, y1 = crop
            frames = [f[y0:y1, x0:x1] for f in frames]
        rows.append(np.concatenate(frames, axis=1))
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    Image.fromarray(np.concatenate(rows, axis=0)).save(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fps", type=float, default=24)
    ap.add_argument("--figure", default=None, help="write the comparison strips here (a folder)")
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="bench-inbetween-")
    cases = [
        ("arm 180°, 2 keys", arm_scene(tmp, "two"), None, None, ("shoulder", "hand")),
        ("arm 180°, 3 keys", arm_scene(tmp, "three"), None, None, ("shoulder", "hand")),
        ("joined arm 180°, 2 keys", arm_scene(tmp, "two", True), None, None, ("shoulder", "hand")),
        ("joined arm 180°, 3 keys", arm_scene(tmp, "three", True), None, None, ("shoulder", "hand")),
        ("character wave (0-0.4 s)", os.path.join(HERE, "assets/scenes/character.json"), 0.0, 0.4, None),
        ("character, whole", os.path.join(HERE, "assets/scenes/character.json"), None, None, None),
        ("trex-layers, whole", os.path.join(HERE, "assets/scenes/trex-layers.json"), None, None, None),
    ]
    print(f"load {os.getloadavg()[0]:.2f}; {args.fps:g} fps; frames strictly between keys")
    print(f"{'case':25s} {'mode':7s} {'frames':>6s} {'min area':>9s} {'1% area':>8s} {'flipped':>7s} "
          f"{'overlap':>8s} {'stretch':>8s} {'squash':>7s} {'arm':>6s} {'ms/frame':>9s}")
    for name, path, t0, t1, arm in cases:
        for mode in ("linear", "rigid"):
            m = measure(path, mode, args.fps, t0, t1, arm)
            armtxt = f"{m['arm']:.3f}" if np.isfinite(m["arm"]) else "-"
            print(f"{name:25s} {mode:7s} {m['frames']:6d} {m['amin']:9.3f} {m['p1']:8.3f} {m['folded']:7d} "
                  f"{m['over']:8d} {m['smax']:8.3f} {m['smin']:7.3f} {armtxt:>6s} {m['ms']:9.1f}", flush=True)
    if args.figure:
        figure(os.path.join(tmp, "arm-two.json"), os.path.join(args.figure, "inbetween-arm.png"),
               [0, 0.25, 0.5, 0.75, 1.0], crop=(40, 100, 440, 640))
        figure(os.path.join(tmp, "arm-three-joined.json"), os.path.join(args.figure, "inbetween-joined.png"),
               [0, 0.5, 1.0, 1.25, 1.5, 1.75, 2.0], crop=(40, 100, 440, 640))
        figure(os.path.join(HERE, "assets/scenes/character.json"), os.path.join(args.figure, "inbetween-character.png"),
               [0, 0.1, 0.2, 0.3, 0.4], size=(350, 350))
        print(f"figures in {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
