"""Does a solve leave the window's thread free? The two options of issue 21, measured.

1. Back-substitutions on two threads at once (20 single right-hand sides each) against
   one thread: a factoriser that releases the GIL takes about as long on two threads as
   on one (2 cores), one that holds it twice as long.
2. A "window" on the main thread (at 60 Hz, 2 ms of pure-Python work per frame, holding
   the GIL as pyglet, ImGui and moderngl calls do) while drag previews run without pause:
   - ``none``: no solver (the floor: what the window gets alone, in the same run);
   - ``thread/qdldl``: ``DragSession.move_layers`` on a second thread, QDLDL (default);
   - ``thread/qdldl switch 1 ms``: the same with ``sys.setswitchinterval(0.001)`` (a
     thread waiting for the GIL asks for it after 1 ms instead of 5);
   - ``thread/cholespy``: the same with the group's factor swapped for CHOLMOD;
   - ``process``: the session's previews solved in a
     :class:`~puppet.scene.drag.process.DragProcess` (a child ``python``, a socket pair), the
     moved layers sent back per move, the main process's second thread only waiting.
   Reported: how late the window's frames are (median, p90, p99, longest: a stall) and
   the previews per second the solver gave meanwhile.

    .venv/bin/python benchmarks/bench_solver.py [--scene PATH --pin NAME] [--seconds 3]
"""
from __future__ import annotations

import argparse
import os
import sys
import threading
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from puppet.deform import factor  # noqa: E402
from puppet.scene.document.core import Document  # noqa: E402

SCENES = os.path.join(ROOT, "assets", "scenes")


def drag_point(at, k: int) -> tuple[float, float]:
    a = 0.05 * k
    return (at[0] + 40 * np.sin(a), at[1] + 25 * (1 - np.cos(a)))


# -- 1. two threads of back-substitutions ----------------------------------------------
def back_substitutions(doc: Document) -> list[tuple[str, float, float]]:
    built = doc.built
    g = max(range(len(built.groups)), key=lambda i: len(built.groups[i].mesh.V))
    A = built.pre[g].arap
    Lff = A.L[A.free][:, A.free]
    rhs = np.random.default_rng(0).normal(size=len(A.free))
    rows = []
    for kind in factor.SOLVERS:
        f = A.factor if kind == A.factor.kind else factor.factorize(Lff, kind)
        if f.kind != kind:
            continue
        solve = f.solve1 if hasattr(f, "solve1") else f.solve

        def twenty():
            for _ in range(20):
                solve(rhs)
        twenty()
        t0 = time.perf_counter()
        twenty()
        one = time.perf_counter() - t0
        threads = [threading.Thread(target=twenty) for _ in range(2)]
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        rows.append((kind, one, time.perf_counter() - t0))
    return rows


# -- 2. the window's thread while previews run --------------------------------------------
def calibrate(target: float = 2e-3) -> int:
    n = 1000
    while True:
        t0 = time.perf_counter()
        sum(i * i for i in range(n))
        dt = time.perf_counter() - t0
        if dt > target / 4:
            return int(n * target / dt)
        n *= 2


def window(seconds: float, n: int, rate: float = 60.0) -> np.ndarray:
    """A 60 Hz window on the main thread: at each frame time, ~2 ms of pure-Python work.
    Returns each frame's delay (s): when its work ended, less when it was due and what
    the work takes alone (``n`` from :func:`calibrate`)."""
    def work():
        sum(i * i for i in range(n))
    t0 = time.perf_counter()
    work()
    alone = time.perf_counter() - t0
    delays = []
    start = time.perf_counter()
    for k in range(int(seconds * rate)):
        due = start + k / rate
        time.sleep(max(0.0, due - time.perf_counter()))
        work()
        delays.append(max(0.0, time.perf_counter() - due - alone))
    return np.asarray(delays)


def in_thread(doc: Document, pin: str, stop: threading.Event, count: list) -> None:
    d = doc.drag(pin)
    at = next(p.at for p in doc.data.pins if p.name == pin)
    k = 0
    while not stop.is_set():
        d.move_layers(drag_point(at, k))
        k += 1
    count.append(k)
    d.cancel()


def in_process(path: str, pin: str, stop: threading.Event, count: list, ready: threading.Event) -> None:
    """The drag session of a second copy of the scene, its previews solved in a
    :class:`~puppet.scene.drag.process.DragProcess` (this thread only waits on its socket)."""
    from puppet.scene.drag.process import DragProcess

    doc = Document.load(path)
    proc = DragProcess()
    d = doc.drag(pin, solver=proc)
    proc.wait_ready(d._serial)
    at = next(p.at for p in doc.data.pins if p.name == pin)
    ready.set()
    k = 0
    while not stop.is_set():
        d.move_layers(drag_point(at, k))
        k += 1
    count.append(k)
    assert not d._U, "a preview was solved in this process"
    d.cancel()
    proc.close()


def run_mode(mode: str, doc: Document, path: str, pin: str, seconds: float, n: int) -> dict:
    stop, count, ready = threading.Event(), [], threading.Event()
    swapped = None
    if mode == "none":
        return {"ticks": window(seconds, n), "moves": 0.0}
    if mode == "thread/cholespy":
        i = [p.name for p in doc.data.pins].index(pin)
        A = doc.built.pre[doc.built.group_of_pin(i)].arap
        swapped = (A, A.factor)
        A.factor = factor.factorize(A.L[A.free][:, A.free], "cholespy")
    interval = sys.getswitchinterval()
    if mode.endswith("switch 1 ms"):
        sys.setswitchinterval(0.001)
    if mode.startswith("thread"):
        worker = threading.Thread(target=in_thread, args=(doc, pin, stop, count))
        ready.set()
    else:
        worker = threading.Thread(target=in_process, args=(path, pin, stop, count, ready))
    worker.start()
    ready.wait()
    time.sleep(0.2)
    t0 = time.perf_counter()
    ticks = window(seconds, n)
    stop.set()
    worker.join()
    elapsed = time.perf_counter() - t0
    sys.setswitchinterval(interval)
    if swapped is not None:
        swapped[0].factor = swapped[1]
    return {"ticks": ticks, "moves": count[0] / elapsed}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default=os.path.join(SCENES, "trex-layers.json"))
    ap.add_argument("--pin", default="hand_front")
    ap.add_argument("--seconds", type=float, default=3.0)
    a = ap.parse_args()
    from threadpoolctl import threadpool_info

    print(f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}; BLAS pools: "
          f"{[(i['internal_api'], i['num_threads']) for i in threadpool_info()]}")
    doc = Document.load(a.scene)
    nv = max(len(g.mesh.V) for g in doc.built.groups)
    print(f"{os.path.basename(a.scene)}: largest group {nv} vertices; drag {a.pin}\n")
    print(f"{'factor':10s} {'20 solves':>10s} {'2 threads x 20':>15s} {'ratio':>6s}   (ms; ~1: GIL released, ~2: held)")
    for kind, one, two in back_substitutions(doc):
        print(f"{kind:10s} {1e3 * one:10.1f} {1e3 * two:15.1f} {two / one:6.2f}")
    n = calibrate()
    print(f"\n{'solver':24s} {'frame delay med':>15s} {'p90':>6s} {'p99':>6s} {'longest':>8s} {'previews/s':>11s}"
          "   (ms; a 60 Hz window doing 2 ms of Python per frame)")
    for mode in ("none", "thread/qdldl", "thread/qdldl switch 1 ms", "thread/cholespy", "process"):
        r = run_mode(mode, doc, a.scene, a.pin, a.seconds, n)
        ms = 1e3 * r["ticks"]
        print(f"{mode:24s} {np.median(ms):15.2f} {np.percentile(ms, 90):6.2f} {np.percentile(ms, 99):6.2f} "
              f"{ms.max():8.2f} {r['moves']:11.1f}")

if __name__ == "__main__":
    main()
