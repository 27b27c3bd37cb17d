"""Which jobs a worker runs next: handed out as workers free up, not planned in advance.

Jobs differ in cost by 10x and more (a frame of the 7.7k-vertex T-rex against a pose of a
small cut-out), and a worker builds each scene it renders once. The client keeps every
worker a piece ahead (:data:`DEPTH`) and, each time a piece comes back, gives that worker
its next one:

1. an animation (each its own task; all of them first, so none ends the batch alone);
2. more jobs of a scene this worker has built already (its cache holds it: no second build);
3. else a share of a scene another worker has started, when that scene's work left (its
   jobs not handed out and those still running or queued) exceeds a worker's share of all
   the work left by more than a build, so its owner would end the batch alone, and a
   second build pays for itself (times learnt from the jobs done so far: a scene's mean
   job, and its slowest one, which includes the build);
4. else a scene nobody has started, the one with the most jobs first;
5. else a share of the scene with the most work left, when a second build pays (before
   any job is timed: when two pieces' worth are left).

Measured on the 200 bench jobs: planned by job count, 102 and 98 jobs took 2.63 s and
1.59 s on the two workers; handed out this way, the two end within ~0.1 s.

Pieces shrink as the batch ends (about a quarter of a worker's share of what is left, timed
by the jobs done so far), so the workers finish within a small piece of each other.
"""
from __future__ import annotations

import math
import statistics
from collections import deque

#: Most jobs in one Dask task (a piece shares the worker's loaded scene); pieces of a scene
#: whose jobs are not timed yet hold at most :data:`FIRST_PIECE`. Fewer, larger tasks cost
#: the client's process less (Dask's scheduler and client: ~6 ms of CPU a task here, which
#: two busy workers feel): 8 -> 32 took it from 0.23-0.33 to 0.15-0.24 s on the 200 bench jobs.
MAX_PIECE = 32
FIRST_PIECE = 8
#: Tasks kept queued on a worker per thread, plus one: the next one is already there when
#: a task ends, so a worker never waits for the client's round trip.
DEPTH = 1


class Feeder:
    """Jobs not handed out yet, by scene, and the scenes each worker has been given.

    Parameters
    ----------
    jobs : list of dict
        Jobs with ``id``, ``scene`` and ``kind`` (see :mod:`puppet.batch.jobs`).
    """

    def __init__(self, jobs: list[dict]):
        self.alone: deque[dict] = deque(j for j in jobs if j["kind"] == "animate")
        self.queues: dict[str, deque[dict]] = {}
        for j in jobs:
            if j["kind"] != "animate":
                self.queues.setdefault(j["scene"], deque()).append(j)
        self.built: dict[str, set[str]] = {}
        self.times: dict[str, list[float]] = {}  # scene -> seconds of its jobs done so far
        self.out: dict[str, int] = {}            # scene -> jobs handed out, no record back yet

    def learn(self, piece: list[dict], records: list[dict]) -> None:
        """Take the records of a piece that came back (as ``run_job`` gives them): the
        seconds of the jobs done, and the piece is no longer outstanding."""
        scene = {j["id"]: j["scene"] for j in piece if j.get("kind") != "animate"}
        for r in records:
            s = scene.get(r["id"])
            if s is None:
                continue
            self.out[s] = max(0, self.out.get(s, 0) - 1)
            if r.get("status") == "done" and r.get("seconds") is not None:
                self.times.setdefault(s, []).append(float(r["seconds"]))

    def __len__(self) -> int:
        """Jobs not handed out yet."""
        return len(self.alone) + sum(len(q) for q in self.queues.values())

    def _job_seconds(self) -> tuple[dict[str, float], float | None]:
        """Mean seconds of a job of each scene timed so far, and the median of those (None:
        none timed). The slowest job is left out of the mean: a scene's first job on a worker
        also builds it. (Not the median job: the frames of an animation that start a new
        pair of keys cost several times the others.)"""
        known = {s: _mean_job(ts)[0] for s, ts in self.times.items() if ts}
        return known, (statistics.median(known.values()) if known else None)

    def _work(self, scene: str, known: dict[str, float], typical: float) -> float:
        """Seconds of ``scene``'s jobs not handed out, and handed out but not back."""
        return (len(self.queues[scene]) + self.out.get(scene, 0)) * known.get(scene, typical)

    def _share(self, scene: str, size: int) -> int:
        """How many of ``scene``'s jobs a worker that has not built it should take (0: none)."""
        left = len(self.queues[scene])
        ts = self.times.get(scene, ())
        if len(ts) < 2:
            return size if left >= 2 * size else 0
        job, build = _mean_job(ts)
        total = left + self.out.get(scene, 0)
        # the owner runs total - k jobs while the helper builds and runs k: balanced at k
        k = int((total * job - build) / (2 * job)) if job > 0 else left // 2
        return max(0, min(size, k, left)) if total * job > build + 2 * job else 0

    def piece_size(self, workers: int, scene: str | None = None) -> int:
        """Jobs in the next piece of ``scene``: about a quarter of a worker's share of what
        is left, in seconds once the scene's jobs are timed (so a slow scene's pieces shrink
        like the others' as the batch ends; at most :data:`MAX_PIECE`), else in jobs (at
        most :data:`FIRST_PIECE`)."""
        share = 4 * max(1, workers)
        known, typical = self._job_seconds()
        if scene not in known:
            return max(1, min(FIRST_PIECE, math.ceil(len(self) / share)))
        seconds = sum(len(q) * known.get(s, typical) for s, q in self.queues.items())
        return max(1, min(MAX_PIECE, int(seconds / share / known[scene]) if known[scene] > 0 else MAX_PIECE))

    def next(self, worker: str | None, workers: int) -> list[dict]:
        """The next piece for ``worker`` (None: any worker) among ``workers``; [] when
        nothing is left that this worker should take now."""
        if self.alone:
            return [self.alone.popleft()]
        left = {s: q for s, q in self.queues.items() if q}
        if not left:
            return []
        mine = self.built.setdefault(worker, set()) if worker is not None else set()
        started = set().union(*self.built.values()) if self.built else set()
        scene = max((s for s in left if s in mine), key=lambda s: len(left[s]), default=None)
        size = 0
        if scene is None and worker is not None:
            size, scene = self._help(left, started, workers)
        if scene is None:
            scene = max((s for s in left if s not in started), key=lambda s: len(left[s]), default=None)
        if scene is None and worker is None:
            scene = max(left, key=lambda s: len(left[s]))
        if scene is None:
            return []
        size = size or self.piece_size(workers, scene)
        mine.add(scene)
        q = self.queues[scene]
        self.out[scene] = self.out.get(scene, 0) + min(size, len(q))
        return [q.popleft() for _ in range(min(size, len(q)))]

    def _help(self, left: dict, started: set[str], workers: int) -> tuple[int, str | None]:
        """(jobs, scene) of a started scene this worker should share now, else (0, None)."""
        others = [s for s in left if s in started]
        if not others:
            return 0, None
        known, typical = self._job_seconds()
        unstarted = any(s not in started for s in left)
        if typical is None:  # nothing timed yet: share only once nothing else is left
            big = max(others, key=lambda s: len(left[s]))
            k = 0 if unstarted else self._share(big, self.piece_size(workers, big))
            return (k, big) if k else (0, None)
        work = {s: self._work(s, known, typical) for s in self.queues}
        big = max(others, key=work.__getitem__)
        ts = self.times.get(big, ())
        build = _mean_job(ts)[1] if ts else 0.0
        if unstarted and work[big] - sum(work.values()) / max(1, workers) <= build:
            return 0, None  # its owner ends in time, or not by more than a build: a new scene
        k = self._share(big, self.piece_size(workers, big))
        return (k, big) if k else (0, None)

    def rest(self) -> list[list[dict]]:
        """Everything not handed out, in pieces (for workers that are all gone, or a cluster
        with no worker known yet: Dask places them)."""
        out = [[self.alone.popleft()] for _ in range(len(self.alone))]
        while True:
            piece = self.next(None, 1)
            if not piece:
                return out
            out.append(piece)


def _mean_job(seconds: list[float]) -> tuple[float, float]:
    """(mean seconds of a job, seconds of a build) from a scene's job times: the slowest job
    is taken for the one that built the scene."""
    if len(seconds) < 2:
        return seconds[0], 0.0
    slowest = max(seconds)
    job = (sum(seconds) - slowest) / (len(seconds) - 1)
    return job, max(slowest - job, 0.0)
