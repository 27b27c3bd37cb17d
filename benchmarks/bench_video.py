"""Video tracking on puppet-rendered ground-truth clips (issue 13 part 6).

Per clip: TAP-Vid style fraction of visible joints within 1, 2, 4, 8, 16 px of the truth and
their average (delta_avg), median error (visible joints), worst joint's median, lost frames, and
the tracker's frames per second (``Tracker.step`` only, wall clock; clip generation is cached) and
its CPU milliseconds per frame (all threads: a steadier number on a shared machine).
Targets: delta_avg >= 0.85, median <= 2 px over 100 frames at 640x480, tracker >= 20 fps.

    .venv/bin/python benchmarks/bench_video.py [--frames 100] [--size 640x480] [--masks] [--carry-only]
                                               [--clips trex,character]

One function per measurement: ``measure_tracker`` here; end-to-end fps lives beside it.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

THRESHOLDS = (1, 2, 4, 8, 16)


def tap_scores(pred: np.ndarray, truth: np.ndarray, visible: np.ndarray) -> dict:
    """TAP-Vid position accuracy.

    Parameters
    ----------
    pred, truth : (n, k, 2) float arrays
        Predicted and true positions of ``k`` joints on ``n`` frames (frame 0, the query, excluded
        by the caller).
    visible : (n, k) bool array

    Returns
    -------
    dict with ``within`` {threshold: fraction}, ``delta_avg``, ``median``, ``worst_median``.
    """
    err = np.linalg.norm(pred - truth, axis=2)
    err = np.where(np.isnan(err), np.inf, err)
    ev = err[visible]
    within = {t: float(np.mean(ev < t)) for t in THRESHOLDS}
    per_joint = [np.median(err[:, j][visible[:, j]]) for j in range(err.shape[1]) if visible[:, j].any()]
    return {"within": within, "delta_avg": float(np.mean(list(within.values()))),
            "median": float(np.median(ev)), "worst_median": float(max(per_joint))}


def measure_tracker(clip, *, masks: bool = False, **options) -> dict:
    """Track ``clip``'s joints from its first frame; accuracy and tracker frames per second."""
    from puppet.video.track import Tracker

    names = list(clip.joints)
    first = {k: tuple(clip.joints[k][0]) for k in names}
    m = clip.masks if masks else [None] * len(clip.frames)
    import scipy.spatial  # noqa: F401  (imports outside the timing)

    tk = Tracker(clip.frames[0], first, mask=m[0], **options)
    pred = [np.array([first[k] for k in names])]
    lost = 0
    t0, c0 = time.perf_counter(), time.process_time()
    for i in range(1, len(clip.frames)):
        st = tk.step(clip.frames[i], mask=m[i])
        lost += st.lost
        pred.append(np.array([st.joints[k] for k in names]))
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    truth = np.stack([clip.joints[k] for k in names], 1)
    vis = np.stack([clip.visible[k] for k in names], 1)
    out = tap_scores(np.array(pred)[1:], truth[1:], vis[1:])
    out.update(fps=(len(clip.frames) - 1) / dt, cpu_ms=1e3 * cpu / (len(clip.frames) - 1), lost=lost)
    return out


def tracker_table(clips: list[str], *, n: int, size: tuple[int, int], masks: bool, carry_only: bool = False) -> None:
    from puppet.video.clips import load_clip

    print(f"tracker on ground-truth clips: {n} frames at {size[0]}x{size[1]}, masks={'on' if masks else 'off'}; "
          f"load {os.getloadavg()[0]:.2f}")
    head = " ".join(f"<{t:<2d}px" for t in THRESHOLDS)
    print(f"{'clip':13s} {head} {'d_avg':>6s} {'median':>7s} {'worst':>6s} {'lost':>5s} {'fps':>6s} {'cpu ms':>7s}")
    for name in clips:
        clip = load_clip(name, n=n, size=size)
        r = measure_tracker(clip, masks=masks)
        rows = [(name, r)]
        if carry_only:
            rows.append((name + "/tri", measure_tracker(clip, masks=masks, align=False)))
        for name, r in rows:
            _row(name, r)


def _row(name: str, r: dict) -> None:
    cells = " ".join(f"{r['within'][t]:5.3f}" for t in THRESHOLDS)
    print(f"{name:13s} {cells} {r['delta_avg']:6.3f} {r['median']:7.2f} {r['worst_median']:6.2f} "
          f"{r['lost']:5d} {r['fps']:6.1f} {r['cpu_ms']:7.1f}")


def sprite_walk() -> None:
    """The Kenney toon walk (assets/kenney-toon/walk/: idle and walk sprites alternating every 3
    frames while the sprite moves 10 px right per frame). On idle frames the picture is frame 0's
    moved by (10 i, 0): exact truth. On walk frames the drawing differs: only the head has a
    known move, (10 i, -4) plus where the walk sprite draws the head against the idle one
    (found by normalised correlation of the idle head in the walk sprite, times the 3x scale)."""
    import json

    from PIL import Image

    from puppet.video.track import Tracker

    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "assets", "kenney-toon")
    scene = json.load(open(os.path.join(root, "walk.json")))
    folder = os.path.join(root, "walk")
    files = sorted(os.listdir(folder), key=lambda f: int("".join(c for c in f if c.isdigit())))
    frames = [np.array(Image.open(os.path.join(folder, f)).convert("RGB")) for f in files]
    names = [p["name"] for p in scene["pins"]]
    P0 = np.array([p["at"] for p in scene["pins"]], float) - 0.5
    masks = [cv2_gray(f) < 238 for f in frames]
    head_shift = 3 * _head_offset(root)
    tk = Tracker(frames[0], dict(zip(names, map(tuple, P0))), mask=masks[0])
    idle, head, lost, conf = [], [], 0, []
    t0 = time.perf_counter()
    for i in range(1, len(frames)):
        st = tk.step(frames[i], mask=masks[i])
        lost += st.lost
        X = np.array([st.joints[n] for n in names])
        conf.append([st.confidence[n] for n in names])
        walk = (i // 3) % 2 == 1
        truth = P0 + (10 * i, -4 if walk else 0)
        if walk:
            h = names.index("head")
            head.append(np.hypot(*(X[h] - truth[h] - head_shift)))
        else:
            idle.extend(np.hypot(*(X - truth).T))
    fps = (len(frames) - 1) / (time.perf_counter() - t0)
    idle = np.array(idle)
    print(f"kenney walk ({len(frames)} frames 640x480, masks on): idle frames, all joints: median "
          f"{np.median(idle):.2f} px, within 2 px {np.mean(idle < 2):.3f}; walk frames, head: median "
          f"{np.median(head):.2f} px; lost {lost}; mean confidence {np.mean(conf):.2f}; {fps:.1f} fps")


def _head_offset(root: str) -> np.ndarray:
    """Where the walk sprite draws the idle sprite's head, relative to it (sprite pixels)."""
    import cv2
    from PIL import Image

    g = []
    for k in ("idle", "walk3"):
        a = np.array(Image.open(os.path.join(root, f"femaleAdventurer_{k}.png")).convert("RGBA"))
        gray = cv2.cvtColor(a[..., :3], cv2.COLOR_RGB2GRAY)
        gray[a[..., 3] < 128] = 255
        g.append(gray)
    x0, y0 = 25, 20  # the head's box on the idle sprite (96x128): (25, 20) to (70, 60)
    score = cv2.matchTemplate(g[1], g[0][y0:60, x0:70], cv2.TM_CCOEFF_NORMED)
    _, _, _, (x, y) = cv2.minMaxLoc(score)
    return np.array([x - x0, y - y0], float)


def cv2_gray(rgb: np.ndarray) -> np.ndarray:
    import cv2

    return cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)


def main() -> None:
    from puppet.video.clips import clip_names

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--masks", action="store_true", help="give the tracker each frame's foreground mask")
    ap.add_argument("--clips", default=",".join(clip_names()))
    ap.add_argument("--no-sprites", action="store_true", help="skip the Kenney walk sprites")
    ap.add_argument("--carry-only", action="store_true",
                    help="also run without the ECC alignment (key-point triangles alone, the paper's method): rows '/tri'")
    a = ap.parse_args()
    size = tuple(int(v) for v in a.size.split("x"))
    tracker_table(a.clips.split(","), n=a.frames, size=size, masks=a.masks, carry_only=a.carry_only)
    if not a.no_sprites:
        sprite_walk()


if __name__ == "__main__":
    main()
