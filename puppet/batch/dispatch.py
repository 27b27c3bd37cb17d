"""One job runner per Dask worker (a Dask actor, :class:`puppet.batch.work.Runner`), kept
fed by the client: each worker runs a piece while its next one waits (:data:`DEPTH`), and
a client thread per worker hands it the next piece as soon as one comes back
(:mod:`puppet.batch.feed` decides which).

Why actors and not a task per piece: a task goes through the scheduler (graph update,
assignment, completion, the result fetched from the worker, releases: ~18 messages), a
call on an actor goes to its worker and back. Measured here (2 cores, the scheduler in
the client's process): 3.9 ms of the client process's CPU and 10.6 ms round trip per
task, 1.3 ms and 2.1 ms per actor call; on the 200 bench jobs with 2 workers the client
process used 0.10-0.14 s of CPU instead of 0.25-0.40 s, and the batch took 5-15 % less
time, as the client shares the two cores with the workers.

Dask does not restart actors, so this module does what it did for tasks: a worker that
dies (its calls fail with a closed connection) is dropped; the piece it was running
counts one attempt for each of its jobs (after ``retries`` attempts the jobs are failed
with "the workers running this job died"), the piece waiting behind it goes back as it
is, and workers that join (a nanny's replacement, a scaled-up cluster) get a runner of
their own within :data:`WORKERS_EVERY` seconds.
"""
from __future__ import annotations

import collections
import queue
import threading
import time

from puppet.batch.feed import DEPTH, Feeder
from puppet.batch.work import Runner

#: Seconds between two reads of the cluster's worker list while a batch runs.
WORKERS_EVERY = 1.0
#: Seconds a client thread waits on a call before it looks whether the batch was stopped
#: or its worker left the cluster.
POLL = 0.5
#: The error of jobs whose workers died more than ``retries`` times under them.
DIED = "the workers running this job died (it was retried, then given up)"


class Dispatch:
    """Runs pieces of ``feeder``'s jobs on the workers of ``client``; iterate to get
    ``(piece, records)`` as pieces come back, in the calling thread. :meth:`stop` ends
    the hand-out (pieces running on workers finish there, unrecorded)."""

    def __init__(self, client, feeder: Feeder, retries: int):
        self.client, self.feeder, self.retries = client, feeder, int(retries)
        self.lock = threading.Condition()  # guards the feeder and the counts below
        self.results: queue.Queue = queue.Queue()
        self.threads: dict[str, threading.Thread] = {}
        self.gone: set[str] = set()
        self.out: dict[str, int] = {}  # worker -> pieces handed to it and not back
        self.attempts: collections.Counter = collections.Counter()  # job id -> workers died under it
        self.stopping = threading.Event()
        self.alive: set[str] = set()  # the cluster's workers when last looked
        self._seen = -float("inf")

    def __iter__(self):
        while True:
            with self.lock:  # (a piece's results are queued before it stops counting as out)
                finished = self._finished()
            if finished:
                while True:
                    try:
                        yield self.results.get_nowait()
                    except queue.Empty:
                        return
            if time.perf_counter() - self._seen > WORKERS_EVERY:
                self._join_new_workers()
            try:
                item = self.results.get(timeout=WORKERS_EVERY)
            except queue.Empty:
                continue
            yield item

    def busy(self) -> dict[str, int]:
        """Pieces handed to each worker and not back yet."""
        with self.lock:
            return {w: n for w, n in self.out.items() if n}

    def stop(self) -> None:
        self.stopping.set()
        with self.lock:
            self.lock.notify_all()

    # -- the client's threads, one per worker -------------------------------------
    def _join_new_workers(self) -> None:
        self._seen = time.perf_counter()
        workers = sorted(self.client.scheduler_info()["workers"])
        self.alive = set(workers)
        for w in workers:
            if w in self.threads or w in self.gone:
                continue
            try:
                with self.client.as_current():  # the actor's handle needs the client's event loop
                    actor = self.client.submit(Runner, workers=[w], actor=True, pure=False).result(timeout=60)
            except Exception:  # noqa: BLE001 - the worker went away meanwhile: not one of ours
                self.gone.add(w)
                continue
            t = threading.Thread(target=self._feed, args=(w, actor), name=f"puppet-batch {w}", daemon=True)
            self.threads[w] = t
            t.start()

    def _finished(self) -> bool:
        """Every job handed out and back (call with the lock held)."""
        return not len(self.feeder) and not sum(self.out.values())

    def _live(self) -> int:
        return max(1, sum(t.is_alive() for w, t in self.threads.items() if w not in self.gone))

    def _feed(self, w: str, actor) -> None:
        pending: collections.deque = collections.deque()  # (call, piece), in the order they run
        while not self.stopping.is_set():
            with self.lock:
                while len(pending) < 1 + DEPTH and (piece := self.feeder.next(w, self._live())):
                    pending.append((actor.run(piece), piece))
                    self.out[w] = self.out.get(w, 0) + 1
                if not pending:
                    if self._finished():
                        return
                    self.lock.wait(POLL)  # nothing for this worker now: a piece may come back
                    continue
            call, piece = pending[0]
            try:
                recs = self._result(w, call)
            except _Stopped:
                return
            except OSError:  # the worker died (a closed connection): its pieces go back
                self._lost(w, pending)
                return
            except Exception as e:  # noqa: BLE001 - the runner itself failed (a bug): the piece fails
                recs = [{"id": j["id"], "status": "failed", "error": task_error(e), "inputs": None}
                        for j in piece]
            pending.popleft()
            self._back(w, piece, recs)

    def _result(self, w: str, call):
        while True:
            if self.stopping.is_set():
                raise _Stopped
            if w not in self.alive:  # the scheduler has dropped it, whatever its connection says
                raise ConnectionError(f"worker {w} left the cluster")
            try:
                return call.result(timeout=POLL)
            except TimeoutError:
                continue

    def _back(self, w: str, piece: list[dict], recs: list[dict]) -> None:
        with self.lock:
            self.feeder.learn(piece, recs)
            self.results.put((piece, recs))
            self.out[w] -= 1
            self.lock.notify_all()

    def _lost(self, w: str, pending) -> None:
        """Worker ``w`` died with ``pending`` calls: the first was running, the rest waiting."""
        with self.lock:
            self.gone.add(w)
            self.feeder.forget(w)
            for k in reversed(range(len(pending))):  # the last first: they go back in their order
                piece = pending[k][1]
                if k == 0:
                    for j in piece:
                        self.attempts[j["id"]] += 1
                if k == 0 and any(self.attempts[j["id"]] > self.retries for j in piece):
                    recs = [{"id": j["id"], "status": "failed", "inputs": None, "error": DIED} for j in piece]
                    self.feeder.learn(piece, recs)
                    self.results.put((piece, recs))
                else:
                    self.feeder.put_back(piece)
                self.out[w] -= 1
            self.lock.notify_all()


class _Stopped(Exception):
    pass


def task_error(e: BaseException) -> str:
    """One line for a piece whose job runner raised (a bug: jobs record their own errors)."""
    text = str(e).strip().splitlines()
    return f"internal error: {type(e).__name__}: {text[0] if text else ''}".rstrip(": ")
