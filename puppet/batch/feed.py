"""Which jobs a worker runs next: handed out as workers free up, not planned in advance.

Jobs differ in cost by 10x and more (a frame of the 7.7k-vertex T-rex against a pose of a
small cut-out), and a worker builds each scene it renders once. The client keeps every
worker a piece ahead (:data:`DEPTH`) and, each time a piece comes back, gives that worker
its next one:

1. an animation (each its own piece; all of them first, so none ends the batch alone);
2. more jobs of a scene this worker has built already (its cache holds it: no second build);
3. else a share of a scene another worker has started, when that scene's work left (its
   jobs not handed out and those still running or queued) exceeds a worker's share of all
   the work left by more than a build, so its owner would end the batch alone, and a
   second build pays for itself (times learnt from the jobs done so far: a scene's mean
   job, and its slowest one, which includes the build);
4. else a started scene whose workers all died (nobody else would take it), then a scene
   nobody has started, the one with the most jobs first;
5. else a share of the scene with the most work left, when a second build pays (before
   any job is timed: when two pieces' worth are left).

Measured on the 200 bench jobs: planned by job count, 102 and 98 jobs took 2.63 s and
1.59 s on the two workers; handed out this way, the two end within ~0.15 s.

Pieces shrink as the batch ends (about a quarter of a worker's share of what is left, timed
by the jobs done so far), so the workers finish within a small piece of each other.
"""
from __future__ import annotations

import heapq
import math
from collections import deque

#: Most jobs in one piece (it shares the worker's loaded scene). Larger pieces
#: (32) took ~0.08 s of CPU off the client's process per 200 bench jobs (when each piece
#: was a Dask task), but let a scene
#: whose jobs vary in cost take most of its jobs early (the T-rex's first frames timed were
#: cheaper than its average: 17 of its 61 frames fold and are relaxed, 44 ms more each),
#: leaving the other worker idle at the end.
MAX_PIECE = 8
#: Pieces kept waiting on a worker besides the one it runs: the next one is already there
#: when a piece ends, so a worker never waits for the client's round trip.
DEPTH = 1


class Feeder:
    """Jobs not handed out yet, by scene, and the scenes each worker has been given.

    A call costs in proportion to the scenes under way (started, with jobs not handed out
    or not back), not to all the scenes (10 000 one-job scenes: 0.17 s in all, against 44 s
    when every call looked at every scene).

    Parameters
    ----------
    jobs : list of dict
        Jobs with ``id``, ``scene`` and ``kind`` (see :mod:`puppet.batch.jobs`).
    """

    def __init__(self, jobs: list[dict]):
        self.alone: deque[dict] = deque(j for j in jobs if j["kind"] == "animate")
        self.queues: dict[str, deque[dict]] = {}  # scene -> jobs not handed out (none empty)
        for j in jobs:
            if j["kind"] != "animate":
                self.queues.setdefault(j["scene"], deque()).append(j)
        self.n_left = sum(len(q) for q in self.queues.values())
        self._unstarted = [(-len(q), i, s) for i, (s, q) in enumerate(self.queues.items())]
        heapq.heapify(self._unstarted)  # most jobs first; started scenes are skipped when met
        self.started: set[str] = set()
        self.active: set[str] = set()  # started scenes with jobs not handed out
        self.built: dict[str, set[str]] = {}  # worker -> the scenes given to it
        self._mine: dict[str, set[str]] = {}  # worker -> those with jobs not handed out
        self._owners: dict[str, set[str]] = {}  # scene -> the workers given it
        self.out: dict[str, int] = {}  # scene -> jobs handed out whose record is not back (no zeros)
        self.stats: dict[str, list[float]] = {}  # scene -> [jobs timed, their seconds, slowest]
        self._timed_left: set[str] = set()  # timed scenes with jobs not handed out
        self._all = [0, 0.0]  # every job timed: count, seconds

    def __len__(self) -> int:
        """Jobs not handed out yet."""
        return len(self.alone) + self.n_left

    def learn(self, piece: list[dict], records: list[dict]) -> None:
        """Take the records of a piece that came back (as ``run_job`` gives them): the
        seconds of the jobs done, and the piece is no longer outstanding."""
        scene = {j["id"]: j["scene"] for j in piece if j.get("kind") != "animate"}
        for r in records:
            s = scene.get(r["id"])
            if s is None:
                continue
            if self.out.get(s, 0) > 1:
                self.out[s] -= 1
            else:
                self.out.pop(s, None)
            if r.get("status") == "done" and r.get("seconds") is not None:
                t = float(r["seconds"])
                st = self.stats.setdefault(s, [0, 0.0, 0.0])
                st[0], st[1], st[2] = st[0] + 1, st[1] + t, max(st[2], t)
                self._all[0] += 1
                self._all[1] += t
                if s in self.queues:
                    self._timed_left.add(s)

    # -- estimates ----------------------------------------------------------------
    def _typical(self) -> float | None:
        """Mean seconds of all the jobs timed so far (None: none yet)."""
        return self._all[1] / self._all[0] if self._all[0] else None

    def _job(self, scene: str) -> tuple[float, float] | None:
        """(mean seconds of a job of ``scene``, seconds of its build), None before one is
        timed. The slowest job is left out of the mean: it is taken for the one that built
        the scene. (Not the median: frames of an animation differ several times in cost;
        those whose in-between folds are relaxed, 17 of the T-rex's 61, cost 44 ms more.)"""
        st = self.stats.get(scene)
        if st is None:
            return None
        n, total, slowest = st
        if n < 2:
            return total, 0.0
        job = (total - slowest) / (n - 1)
        return job, max(slowest - job, 0.0)

    def _work(self, typical: float, *, out: bool) -> tuple[dict[str, float], float]:
        """Seconds of each scene under way (its jobs not handed out, and with ``out`` also
        those not back), and of all jobs so counted, other scenes' at ``typical``."""
        under_way = self.active | self._timed_left | (set(self.out) if out else set())
        work, counted = {}, 0
        for s in under_way:
            q = len(self.queues.get(s, ()))
            timed = self._job(s)
            work[s] = (q + (self.out.get(s, 0) if out else 0)) * (timed[0] if timed else typical)
            counted += q
        return work, sum(work.values()) + (self.n_left - counted) * typical

    def piece_size(self, workers: int, scene: str | None = None) -> int:
        """Jobs in the next piece of ``scene``: about a quarter of a worker's share of what
        is left, in seconds once the scene's jobs are timed (so a slow scene's pieces shrink
        like the others' as the batch ends), else in jobs; at most :data:`MAX_PIECE`."""
        share = 4 * max(1, workers)
        timed = self._job(scene) if scene is not None else None
        if timed is None:
            return max(1, min(MAX_PIECE, math.ceil(len(self) / share)))
        if timed[0] <= 0:
            return MAX_PIECE
        seconds = self._work(self._typical(), out=False)[1]
        return max(1, min(MAX_PIECE, int(seconds / share / timed[0])))

    def _share(self, scene: str, size: int) -> int:
        """How many of ``scene``'s jobs a worker that has not built it should take (0: none)."""
        left = len(self.queues[scene])
        st = self.stats.get(scene)
        if st is None or st[0] < 2:
            return size if left >= 2 * size else 0
        job, build = self._job(scene)
        total = left + self.out.get(scene, 0)
        # the owner runs total - k jobs while the helper builds and runs k: balanced at k
        k = int((total * job - build) / (2 * job)) if job > 0 else left // 2
        return max(0, min(size, k, left)) if total * job > build + 2 * job else 0

    # -- handing out --------------------------------------------------------------
    def next(self, worker: str, workers: int) -> list[dict]:
        """The next piece for ``worker`` among ``workers``; [] when nothing is left that
        this worker should take now."""
        if self.alone:
            return [self.alone.popleft()]
        if not self.queues:
            return []
        scene = max(self._mine.get(worker, ()), key=lambda s: len(self.queues[s]), default=None)
        size = 0
        if scene is None:
            size, scene = self._help(workers)
        if scene is None:
            scene = self._orphaned() or self._largest_unstarted()
        if scene is None:
            return []
        return self._take(scene, worker, size or self.piece_size(workers, scene))

    def _largest_unstarted(self) -> str | None:
        while self._unstarted and self._unstarted[0][2] in self.started:
            heapq.heappop(self._unstarted)
        return self._unstarted[0][2] if self._unstarted else None

    def _orphaned(self) -> str | None:
        """The scene under way with the most jobs left whose every worker is gone
        (:meth:`forget`): nobody takes its jobs as their own, and sharing them (:meth:`_help`)
        may never pay a build, so they are handed out like a scene nobody has started."""
        return max((s for s in self.active if not self._owners.get(s)), key=lambda s: len(self.queues[s]),
                   default=None)

    def _help(self, workers: int) -> tuple[int, str | None]:
        """(jobs, scene) of a scene another worker started that this one should share
        now, else (0, None)."""
        if not self.active:
            return 0, None
        unstarted = self._largest_unstarted() is not None
        typical = self._typical()
        if typical is None:  # nothing timed yet: share only once nothing else is left
            big = max(self.active, key=lambda s: len(self.queues[s]))
            k = 0 if unstarted else self._share(big, self.piece_size(workers, big))
            return (k, big) if k else (0, None)
        work, total = self._work(typical, out=True)
        big = max(self.active, key=work.__getitem__)
        timed = self._job(big)
        build = timed[1] if timed else 0.0
        if unstarted and work[big] - total / max(1, workers) <= build:
            return 0, None  # its owner ends in time, or not by more than a build: a new scene
        k = self._share(big, self.piece_size(workers, big))
        return (k, big) if k else (0, None)

    def _take(self, scene: str, worker: str, size: int) -> list[dict]:
        q = self.queues[scene]
        if scene not in self.started:
            self.started.add(scene)
            self.active.add(scene)
        piece = [q.popleft() for _ in range(min(size, len(q)))]
        self.n_left -= len(piece)
        self.out[scene] = self.out.get(scene, 0) + len(piece)
        self.built.setdefault(worker, set()).add(scene)
        self._mine.setdefault(worker, set()).add(scene)
        self._owners.setdefault(scene, set()).add(worker)
        if not q:
            del self.queues[scene]
            self.active.discard(scene)
            self._timed_left.discard(scene)
            for w in self._owners.get(scene, ()):
                self._mine[w].discard(scene)
        return piece

    def put_back(self, piece: list[dict]) -> None:
        """Take back a piece handed out but not done (its worker died): its jobs are the
        next of their scene (an animation, the next animation), for any worker."""
        for j in reversed(piece):
            if j["kind"] == "animate":
                self.alone.appendleft(j)
                continue
            s = j["scene"]
            if self.out.get(s, 0) > 1:
                self.out[s] -= 1
            else:
                self.out.pop(s, None)
            q = self.queues.get(s)
            if q is None:  # every job of the scene had been handed out: under way again
                q = self.queues[s] = deque()
                self.active.add(s)
                if s in self.stats:
                    self._timed_left.add(s)
                for w in self._owners.get(s, ()):
                    self._mine.setdefault(w, set()).add(s)
            q.appendleft(j)
            self.n_left += 1

    def forget(self, worker: str) -> None:
        """``worker`` is gone: the scenes it built count for no one else."""
        for s in self.built.pop(worker, set()):
            owners = self._owners.get(s)
            if owners is not None:
                owners.discard(worker)
        self._mine.pop(worker, None)
