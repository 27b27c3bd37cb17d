"""The export pipeline: solve, composite and encode overlapped on three threads.

A frame goes through three stages:

1. **solve** (CPU: numpy/scipy ARAP, :meth:`Document.layers`): a *solver thread* solves
   frame n+1 ...
2. **composite** (OpenGL: :meth:`Scene.draw_layers`) on the *calling thread* (the only
   one that touches GL) draws frame n ...
3. **encode** (the sink: PNG deflate, LZW, x264, libvpx ...): an *encoder thread* writes
   frame n-1.

With several solver processes (``animate --workers N``) the solver thread only passes on
what :class:`puppet.anim.solver.SolverPool` hands back in order, and a sink whose frames
encode apart has them encoded on N threads (:func:`ahead`) before the encoder thread
writes them in order.

The stages hand frames over through queues of :data:`DEPTH` items, so at most a few
frames exist at once (memory is flat in the frame count), and frames are written in
order. Each frame is solved from its own time (trajectory invariance), so the output is
identical to the sequential path (``threads=False``), which runs the same stage
functions one after the other. An error in any stage stops the others and is raised in
the calling thread; so is a signal (the threads are stopped first, so no stage writes
into a temporary output that is being removed).

A signal's exception can land anywhere in the calling thread, even inside a lock's or
a queue's own code, and leave a lock taken that a stage then waits on for ever (an
import's module lock, a queue's mutex). So the calling thread never waits on a stage
without a bound and never inside ``Thread.join``: a stage is started inside the ``try``
that stops it, its end is a flag it sets (looked at in short sleeps), and a stopped stage
is given :data:`HALT_TIMEOUT` seconds to end before it is left behind (a daemon thread,
blocked, not writing).
"""
from __future__ import annotations

import os
import queue
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout

import numpy as np

#: Frames waiting between two stages (per queue).
DEPTH = 2
#: Seconds a stopped stage gets to end (its current solve or encode) before it is left behind.
HALT_TIMEOUT = 10.0
_END = object()


class Timings(dict):
    """Seconds spent per stage: ``solve``, ``composite``, ``encode`` (work) and ``wait``
    (the calling thread waiting for a solve or for room at the encoder)."""

    _lock = threading.Lock()  # several encoding threads add to "encode"

    def add(self, stage: str, seconds: float) -> None:
        with self._lock:
            self[stage] = self.get(stage, 0.0) + seconds


class _Stop(Exception):
    pass


class _StageThread(threading.Thread):
    """One stage of the pipeline (solving, encoding) on a daemon thread running ``body(put)``;
    ``put`` blocks on a bounded queue unless stopped."""

    def __init__(self, name: str, body: Callable):
        super().__init__(name=name, daemon=True)
        self.body, self.error = body, None
        self.stop = threading.Event()
        # Plain flags, read by the calling thread without a lock (a signal's exception there
        # never lands inside Thread.join or is_alive, whose lock handling it can upset).
        self.starting = False  # start() was called (a signal may cut it short after that)
        self.ended = False  # run() has returned

    def start(self) -> None:
        self.starting = True
        try:
            super().start()
        except Exception:  # no thread could be started: nothing to wait for
            self.starting = False
            raise

    def run(self) -> None:
        try:
            if not self.stop.is_set():
                self.body()
        except _Stop:
            pass
        except BaseException as e:  # handed to the calling thread
            self.error = e
        finally:
            self.ended = True

    def running(self) -> bool:
        """Started and not ended (a stage whose start() was cut short counts as running)."""
        return self.starting and not self.ended

    def put(self, q: queue.Queue, item) -> None:
        while not self.stop.is_set():
            try:
                q.put(item, timeout=0.05)
                return
            except queue.Full:
                pass
        raise _Stop

    def get(self, q: queue.Queue):
        while not self.stop.is_set():
            try:
                return q.get(timeout=0.05)
            except queue.Empty:
                pass
        raise _Stop

    def halt(self, timeout: float | None = None) -> bool:
        """Stop the stage and wait at most ``timeout`` seconds (:data:`HALT_TIMEOUT`) for
        it to end; True when it has. A thread whose ``start()`` was cut short by a signal
        (it may or may not run) is waited for the same way."""
        self.stop.set()
        end = time.monotonic() + (HALT_TIMEOUT if timeout is None else timeout)
        while self.running() and time.monotonic() < end:
            time.sleep(0.005)
        return not self.running()

    def wait(self) -> None:
        """Wait for the stage to end (a signal is handled meanwhile)."""
        while self.running():
            time.sleep(0.002)


class Progress:
    """A tqdm bar (frames, rate, ETA) on stderr when ``show``; silent otherwise. A terminal
    that goes away (SIGHUP) only stops the bar."""

    def __init__(self, total: int, show: bool):
        self.bar = None
        if show:
            from tqdm import tqdm

            try:  # a terminal that reports no size (a bare pty) gets 80x24, not a hidden bar
                known = min(os.get_terminal_size(sys.stderr.fileno())) > 0
            except (OSError, ValueError):
                known = False
            self.bar = tqdm(total=total, unit="frame", file=sys.stderr, leave=True, smoothing=0.1,
                            dynamic_ncols=known, ncols=None if known else 80, nrows=None if known else 24)

    def update(self) -> None:
        if self.bar is not None:
            try:
                self.bar.update(1)
            except (OSError, ValueError):
                self.bar = None

    def close(self) -> None:
        if self.bar is not None:
            try:
                self.bar.close()
            except (OSError, ValueError):
                pass
            self.bar = None


def _solver(solve: Callable[[int], object], indices: list[int], out: queue.Queue, timings: Timings,
            remote=None):
    """A thread that puts ``(i, solve(i))`` for each index, then the end mark; with
    ``remote`` (a :class:`puppet.anim.solver.ProcessSolver` or pool), the frames are solved
    (and maybe drawn) there and this thread only passes them on, adding the seconds each
    stage took there to ``timings``."""
    def body():
        if remote is not None:
            for i, item, times in remote.results(indices, worker.stop.is_set):
                for stage, seconds in times.items():
                    timings.add(stage, seconds)
                worker.put(out, (i, item))
        else:
            for i in indices:
                t = time.perf_counter()
                item = solve(i)
                timings.add("solve", time.perf_counter() - t)
                worker.put(out, (i, item))
        worker.put(out, (None, _END))
    worker = _StageThread("puppet-solve", body)
    return worker


def _encoder(add: Callable[[np.ndarray], None], inbox: queue.Queue, timings: Timings):
    """A thread that feeds frames from ``inbox`` to ``add`` until the end mark."""
    def body():
        while True:
            frame = worker.get(inbox)
            if frame is _END:
                return
            t = time.perf_counter()
            add(frame)
            timings.add("encode", time.perf_counter() - t)
    worker = _StageThread("puppet-encode", body)
    return worker


def frames(solve: Callable[[int], object], composite: Callable[[object], np.ndarray], indices: list[int], *,
           threads: bool = True, timings: Timings | None = None, remote=None) -> Iterator[np.ndarray]:
    """Frames ``composite(solve(i))`` for ``i`` in ``indices``, in order, solving ahead on
    a thread when ``threads`` (compositing stays on the caller's thread), or in the
    started ``remote`` solver process (see :mod:`puppet.anim.solver`)."""
    timings = Timings() if timings is None else timings
    if not threads:
        for i in indices:
            t = time.perf_counter()
            item = solve(i)
            t1 = time.perf_counter()
            rgba = composite(item)
            timings.add("solve", t1 - t)
            timings.add("composite", time.perf_counter() - t1)
            yield rgba
        return
    q: queue.Queue = queue.Queue(DEPTH)
    worker = _solver(solve, indices, q, timings, remote)
    try:
        worker.start()
        while True:
            t = time.perf_counter()
            while True:
                try:
                    _, item = q.get(timeout=0.1)
                    break
                except queue.Empty:
                    if not worker.running() and q.empty():
                        raise worker.error or RuntimeError("the solver thread stopped") from None
            t1 = time.perf_counter()
            timings.add("wait", t1 - t)
            if item is _END:
                break
            rgba = composite(item)
            timings.add("composite", time.perf_counter() - t1)
            yield rgba
    finally:
        worker.halt()
    if worker.error is not None:
        raise worker.error


def ahead(source: Iterator, work: Callable, n: int, timings: Timings | None = None) -> Iterator:
    """``work(item)`` for each item of ``source``, in order, computed on ``n`` threads at
    once (PNG deflate, GIF quantizing: C code that lets go of the GIL), at most ``n``
    items taken from ``source`` and not yet handed on. The calling thread takes the items
    (compositing them) while the threads work, and waits for a result in short, bounded
    waits. Closing the generator (or an error) cancels what has not started and closes
    ``source``."""
    timings = Timings() if timings is None else timings

    def timed(item):
        t = time.perf_counter()
        out = work(item)
        timings.add("encode", time.perf_counter() - t)
        return out

    pool = ThreadPoolExecutor(n, thread_name_prefix="puppet-encode")
    pending: list = []
    try:
        for item in source:
            pending.append(pool.submit(timed, item))
            if len(pending) >= n:
                yield _result(pending.pop(0))
        while pending:
            yield _result(pending.pop(0))
    finally:
        for f in pending:
            f.cancel()
        pool.shutdown(wait=False, cancel_futures=True)
        close = getattr(source, "close", None)
        if close is not None:
            close()


def _result(future):
    """A future's result, waited for in 0.1 s steps (a signal is handled meanwhile)."""
    while True:
        try:
            return future.result(timeout=0.1)
        except FutureTimeout:
            pass


def run(source: Iterator[np.ndarray], add: Callable[[np.ndarray], None], *, threads: bool = True,
        progress: Progress | None = None, timings: Timings | None = None) -> int:
    """Feed every frame of ``source`` to ``add`` (on an encoder thread when ``threads``);
    returns the number of frames. Errors of either side are raised here, after the
    encoder thread has stopped."""
    timings = Timings() if timings is None else timings
    n = 0
    if not threads:
        for rgba in source:
            t = time.perf_counter()
            add(rgba)
            timings.add("encode", time.perf_counter() - t)
            n += 1
            if progress:
                progress.update()
        return n
    inbox: queue.Queue = queue.Queue(DEPTH)
    worker = _encoder(add, inbox, timings)
    try:
        worker.start()
        for rgba in source:
            t = time.perf_counter()
            while True:
                if worker.error is not None or not worker.running():
                    raise worker.error or RuntimeError("the encoder thread stopped")
                try:
                    inbox.put(rgba, timeout=0.1)
                    break
                except queue.Full:
                    pass
            timings.add("wait", time.perf_counter() - t)
            n += 1
            if progress:
                progress.update()
        while worker.running():  # the end mark, then the last frames are written
            try:
                inbox.put(_END, timeout=0.1)
                break
            except queue.Full:
                pass
        worker.wait()
    finally:
        worker.halt()
        close = getattr(source, "close", None)
        if close is not None:  # a generator: stops its solver thread too
            close()
    if worker.error is not None:
        raise worker.error
    return n
