"""``puppet batch --template ... --dressroom MANNEQUIN``: what the room adds to a template batch.

Run: ``python benchmarks/bench_dressroom_batch.py [--pictures 16] [--rounds 2] [--workers 2]
[--scale LO,HI] [--interleaved]`` from the repository root. The pictures: similarity copies of the bundled room t-shirt
(``assets/scenes/room/t-shirt.png``, the template ``assets/scenes/room/t-shirt.json``,
pose ``fit``) scaled 0.9 to 1.6 and turned up to 20 degrees (370 to 660 px); the mannequin:
``assets/scenes/room/mannequin.json`` (a scene, drawn at rest).

Each round runs the same batch twice on one embedded LocalCluster that is already up,
its workers warm (as ``bench_batch.py``): without ``--dressroom`` and with it (in turn
first: the first run of a round pays for what warms up), each as the
command runs it (its checks, the jobs, ``run_batch``; with ``--dressroom`` the mannequin
drawn before and the room written after). Printed: wall and CPU time (this process +
the workers) of both, the ratio, and where the room's time went. The load average is
printed: the machine is shared.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the puppet command sets it

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

from tests.batch import garments as G  # noqa: E402

ROOM = os.path.join(ROOT, "assets", "scenes", "room")


def pictures(n: int, folder: str, scales=(0.9, 1.6)) -> str:
    rng = np.random.default_rng(11)
    os.makedirs(folder, exist_ok=True)
    for i in range(n):
        scale = rng.uniform(*scales)
        size = int(307 * scale * 1.35)  # the 307 px shirt turned, with a margin
        a = scale * np.exp(1j * np.radians(rng.uniform(-20, 20)))
        b = complex(size / 2, size / 2) - a * complex(153.5, 153.5)  # the shirt's centre at the picture's
        G.similar_copy(os.path.join(ROOM, "t-shirt.png"), os.path.join(folder, f"shirt{i:03d}.png"), scale=scale,
                       angle=float(np.degrees(np.angle(a))), shift=(b.real, b.imag), size=(size, size))
    return folder


def one(client, argv: list[str]) -> tuple[float, float, dict]:
    """Wall and CPU seconds of ``puppet batch ARGV`` as the command runs it, on ``client``;
    and its parts: ``checks`` (the jobs made, with --dressroom the mannequin drawn), ``room``
    (the room written at the end), ``job`` (the jobs' mean seconds on their workers)."""
    from puppet.batch import command as C
    from puppet.batch.runner import run_batch
    from puppet.cli import build_parser

    w0 = client.run(time.process_time)
    t0, c0 = time.perf_counter(), time.process_time()
    args = build_parser().parse_args(["batch", *argv])
    out = os.path.realpath(args.output)
    jobs = C._jobs(args, out)
    parts = {"checks": time.perf_counter() - t0, "room": 0.0}
    os.makedirs(out, exist_ok=True)
    finale = C._finale(args, out, lambda line: None)

    def timed(batch):
        t = time.perf_counter()
        try:
            return finale(batch)
        finally:
            parts["room"] = time.perf_counter() - t
    s = run_batch(jobs, out, client=client, finale=timed if finale else None, **C._reads(args))
    t, c = time.perf_counter() - t0, time.process_time() - c0
    w1 = client.run(time.process_time)
    assert s["counts"]["done"] == len(jobs), s["counts"]
    with open(os.path.join(out, "report.json")) as f:
        parts["job"] = float(np.mean([j["seconds"] for j in json.load(f)["jobs"]]))
    return t, c + sum(w1[k] - w0[k] for k in w1 if k in w0), parts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pictures", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scale", default="0.9,1.6", help="the pictures' scales of the 307 px shirt, LO,HI "
                    "(3,5: catalogue photos of 1100 to 2100 px)")
    ap.add_argument("--interleaved", action="store_true",
                    help="instead: every picture's job run in this process without and with the room, in turn "
                         "first, twice; medians (the machine's drift cancels out)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-room-") as tmp:
        (interleaved if args.interleaved else run)(args, tmp)


def interleaved(args, tmp: str) -> None:
    """Each picture's template job as a worker runs it (``work.run_job``, this process's
    GL context), without and with ``--dressroom``'s room garment, one right after the
    other, in turn first; the per-job difference is what the room adds to a batch's jobs."""
    from puppet.batch import jobs as J
    from puppet.batch import work

    imgs = pictures(args.pictures, os.path.join(tmp, "imgs"), tuple(float(v) for v in args.scale.split(",")))
    template = os.path.join(ROOM, "t-shirt.json")
    work.warm()
    room = {"canvas": [700, 720], "category": "top"}
    plain = J.template_jobs(template, imgs, "fit", os.path.join(tmp, "plain"), {}, tolerance=None)
    with_room = J.template_jobs(template, imgs, "fit", os.path.join(tmp, "room"), {}, tolerance=None, room=room)
    for d in ("plain", "room"):
        os.makedirs(os.path.join(tmp, d), exist_ok=True)
    print(f"{args.pictures} pictures (scale {args.scale}), one process, load before {os.getloadavg()[0]:.2f}")
    t = {"plain": [], "room": []}
    for rep in range(3):
        for k, (a, b) in enumerate(zip(plain, with_room)):
            order = [("plain", a), ("room", b)] if (k + rep) % 2 == 0 else [("room", b), ("plain", a)]
            for name, job in order:
                t0 = time.perf_counter()
                rec = work.run_job(job)
                dt = time.perf_counter() - t0
                assert rec["status"] == "done", rec
                if rep:  # the first pass warms the scene cache and the compositor's targets
                    t[name].append(dt)
    p, r = np.array(t["plain"]), np.array(t["room"])
    print(f"| jobs | a job without, median | with the room, median | per-job difference, median | added |\n"
          f"|---|---|---|---|---|\n| {len(p)} + {len(r)} | {1e3 * np.median(p):.0f} ms | {1e3 * np.median(r):.0f} ms "
          f"| {1e3 * np.median(r - p):.0f} ms | {100 * np.median(r - p) / np.median(p):.1f} % |")
    print(f"load after {os.getloadavg()[0]:.2f}")


def run(args, tmp: str) -> None:
    from puppet.batch import work
    from puppet.batch.cluster import connect

    imgs = pictures(args.pictures, os.path.join(tmp, "imgs"), tuple(float(v) for v in args.scale.split(",")))
    base = ["--template", os.path.join(ROOM, "t-shirt.json"), "--images", imgs, "--pose", "fit"]
    mannequin = os.path.join(ROOM, "mannequin.json")
    print(f"{args.pictures} pictures (scale {args.scale}), {args.workers} workers; load before: "
          f"{os.getloadavg()[0]:.2f}")
    rows = []
    with connect(workers=args.workers) as (client, _):
        client.wait_for_workers(args.workers)
        with client.as_current():
            for addr in client.scheduler_info()["workers"]:
                client.submit(work.Runner, workers=[addr], actor=True, pure=False).result().warm().result()
        for r in range(args.rounds):
            # one after the other, in turn first (the first run of a round pays what warms up)
            if r % 2 == 0:
                plain = one(client, base + ["-o", os.path.join(tmp, f"plain{r}")])
            room = one(client, base + ["-o", os.path.join(tmp, f"room{r}"), "--dressroom", mannequin])
            if r % 2 == 1:
                plain = one(client, base + ["-o", os.path.join(tmp, f"plain{r}")])
            rows.append((plain[:2], room[:2]))
            print(f"round {r}: without {plain[0]:6.2f} s wall {plain[1]:6.2f} s CPU | with --dressroom "
                  f"{room[0]:6.2f} s wall {room[1]:6.2f} s CPU | +{100 * (room[0] / plain[0] - 1):5.1f} % wall, "
                  f"+{100 * (room[1] / plain[1] - 1):5.1f} % CPU; load {os.getloadavg()[0]:.2f}")
            print(f"         a job on its worker {1e3 * plain[2]['job']:.0f} ms without, {1e3 * room[2]['job']:.0f} ms "
                  f"with (+{100 * (room[2]['job'] / plain[2]['job'] - 1):.1f} %); with: checks and mannequin "
                  f"{room[2]['checks']:.2f} s, room written {room[2]['room']:.2f} s")
    p = np.array([[a[0], a[1]] for a, _ in rows])
    q = np.array([[b[0], b[1]] for _, b in rows])
    print(f"\n| | wall s | CPU s |\n|---|---|---|\n| without | {p[:, 0].mean():.2f} | {p[:, 1].mean():.2f} |\n"
          f"| with --dressroom | {q[:, 0].mean():.2f} | {q[:, 1].mean():.2f} |\n"
          f"| added | {100 * (q[:, 0].sum() / p[:, 0].sum() - 1):.1f} % "
          f"| {100 * (q[:, 1].sum() / p[:, 1].sum() - 1):.1f} % |")
    parts(os.path.join(tmp, f"room{args.rounds - 1}"), mannequin)


def parts(out: str, mannequin: str) -> None:
    """Where the room's time goes, in this process (CPU seconds)."""
    from puppet.batch import dressroom
    from puppet.room.model import load_mannequin

    c0 = time.process_time()
    body = load_mannequin(mannequin)
    c1 = time.process_time()
    scenes = sorted(os.path.join(out, "garments", n) for n in os.listdir(os.path.join(out, "garments"))
                    if n.endswith(".json"))
    h, w = body.shape[:2]
    worn, _ = dressroom.garments(scenes, (w, h), mannequin, lambda line: None)
    c2 = time.process_time()
    dressroom.make_room(out, body, mannequin, scenes, inputs=[])
    c3 = time.process_time()
    print(f"\nroom parts (CPU s, this process): mannequin {c1 - c0:.2f}; {len(scenes)} garments drawn "
          f"{c2 - c1:.2f} ({(c2 - c1) / max(len(scenes), 1):.3f} each); garments drawn + page written "
          f"{c3 - c2:.2f}; load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
