"""The client side of a batch: skip what --resume finds up to date, hand out pieces of jobs
to the Dask workers as they free up (:mod:`puppet.batch.dispatch`), record each result as it arrives (manifest, report,
progress bar), and leave OUT_DIR consistent however the run ends (done, failed jobs,
Ctrl+C, SIGTERM)."""
from __future__ import annotations

import contextlib
import os
import shutil
import sys
import time
from collections.abc import Callable

from puppet.batch.cluster import connect
from puppet.batch.dispatch import Dispatch
from puppet.batch.feed import Feeder
from puppet.batch.guard import all_inputs, check_outputs, check_own_files, output_present, scene_inputs
from puppet.batch.jobs import describe, extra_outputs, spec
from puppet.batch.state import Manifest, inputs_digest, now, write_report
from puppet.errors import SceneError

#: Exit status when the batch ran to its end but some jobs failed (0: every job done).
SOME_FAILED = 3
#: Seconds between two rewrites of the manifest while jobs finish (and once at the end).
MANIFEST_EVERY = 1.0


def client_digest(job: dict, cache: dict) -> str | None:
    """The hash the worker would record for ``job`` (None when its scene cannot be read)."""
    from puppet.scene.document.core import Document  # lazy: numpy (see puppet/batch/__init__.py)
    from puppet.scene.format.inputs import input_files  # lazy: numpy (see puppet/batch/__init__.py)

    path = job["scene"]
    if path not in cache:
        try:
            cache[path] = input_files(Document.load(path).data)
        except (SceneError, OSError):
            cache[path] = None
    inputs = cache[path]
    if inputs is None:
        return None
    if job["kind"] == "template":
        inputs = inputs + [(job["image"], "image")]
    try:
        return inputs_digest(spec(job), inputs)
    except (OSError, ValueError):  # unreadable, not a regular file (a FIFO, /dev/zero), a NUL in a name
        return None


def sweep_temporaries(jobs: list[dict], keep: frozenset[str] = frozenset()) -> int:
    """Remove the temporary files and folders (``.NAME.*.tmp``) that a stopped or killed
    worker left beside the outputs (never one of ``keep``, real paths); returns how many."""
    folders: dict[str, set[str]] = {}
    for j in jobs:
        for out in [j["output"].rstrip(os.sep)] + extra_outputs(j):
            base = (os.path.basename(out) or "out")[:100]
            folders.setdefault(os.path.dirname(out), set()).add(f".{base}.")
    n = 0
    for folder, prefixes in folders.items():
        try:
            names = os.listdir(folder)
        except OSError:
            continue
        for name in names:
            if name.endswith(".tmp") and any(name.startswith(p) for p in prefixes):
                path = os.path.join(folder, name)
                if path in keep:
                    continue
                with contextlib.suppress(OSError):
                    shutil.rmtree(path) if os.path.isdir(path) and not os.path.islink(path) else os.remove(path)
                    n += 1
    return n


class Batch:
    """One run over ``jobs`` writing into ``out_dir``; see :func:`run_batch`."""

    def __init__(self, jobs: list[dict], out_dir: str, *, resume: bool, progress: bool):
        self.jobs, self.out_dir = jobs, out_dir
        self.by_id = {j["id"]: j for j in jobs}
        self.resume, self.show = resume, progress
        self.records: dict[int, dict] = {}
        self.manifest = Manifest(out_dir)
        self.started, self.t0 = now(), time.perf_counter()
        self.interrupted = False
        self.cluster = ""
        self._saved = 0.0
        self.bar = None
        self.dispatch: Dispatch | None = None
        self.keep: frozenset[str] = frozenset()  # real paths of the run's inputs (never swept)
        self.checked = False  # guard() passed: report.json is no input of the run
        self.cache: dict = {}  # scene path -> its input files (None: unreadable), for client_digest
        self.room: dict | None = None  # what the report says of --dressroom's room

    # -- before -------------------------------------------------------------------
    def plan(self) -> list[dict]:
        """Jobs to run; those --resume finds up to date are recorded as skipped."""
        todo, cache = [], self.cache
        for j in self.jobs:
            if self.resume and j["rel"] in self.manifest.outputs and output_present(j):
                digest = client_digest(j, cache)
                if digest is not None and self.manifest.matches(j["rel"], digest):
                    self.records[j["id"]] = {"status": "skipped", "error": None, "inputs": digest}
                    continue
            self.manifest.drop(j["rel"])  # re-rendered: not up to date until it is done again
            todo.append(j)
        return todo  # the manifest is saved once the run did something (a result, or its end)

    # -- while --------------------------------------------------------------------
    def run(self, client, todo: list[dict], *, retries: int, on_result: Callable | None = None) -> None:
        """Hand out ``todo`` in pieces to a job runner on each worker as the workers free
        up (see :mod:`puppet.batch.dispatch` and :mod:`puppet.batch.feed`) and record
        each piece's results as they arrive."""
        self.dispatch = Dispatch(client, Feeder(todo), retries)
        self._open_bar(len(todo))
        try:
            for _, recs in self.dispatch:
                self._take(recs)
                if on_result is not None:
                    on_result(self, recs)
        except BaseException:
            self.interrupted = True
            raise
        finally:
            self.dispatch.stop()  # on an interruption: nothing more is handed out
            if self.bar is not None:
                self.bar.close()

    def _open_bar(self, n: int) -> None:
        if not self.show or n == 0:
            return
        from tqdm import tqdm

        self.bar = tqdm(total=n, unit="job", file=sys.stderr, dynamic_ncols=True, smoothing=0.05,
                        bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}, {rate_fmt}{postfix}]")

    def _take(self, recs: list[dict]) -> None:
        for r in recs:
            self.records[r["id"]] = r
            if r["status"] == "done" and r.get("inputs"):
                self.manifest.add(self.by_id[r["id"]]["rel"], r["inputs"])
        if self.manifest.dirty and time.perf_counter() - self._saved > MANIFEST_EVERY:
            self.manifest.save()
            self._saved = time.perf_counter()
        if self.bar is not None:
            c = self.counts()
            self.bar.set_postfix_str(f"done {c['done']}, failed {c['failed'] + c['no-match']}", refresh=False)
            self.bar.update(len(recs))

    # -- after --------------------------------------------------------------------
    def counts(self) -> dict[str, int]:
        c = dict.fromkeys(("done", "failed", "no-match", "skipped", "not-run"), 0)
        for j in self.jobs:
            c[self.records.get(j["id"], {}).get("status", "not-run")] += 1
        return c

    def finish(self, *, manifest: bool = True) -> dict:
        """Remove leftovers of stopped workers; write the manifest (unless ``manifest`` is
        False: stopped before the cluster was there; or the run was stopped before any job
        gave a result) and the report; the summary."""
        sweep_temporaries(self.jobs, keep=self.keep)
        counts = self.counts()
        ran = counts["done"] + counts["failed"] + counts["no-match"]
        if manifest and (ran or not self.interrupted):  # stopped before any result: the manifest stays
            self.manifest.save()
        seconds = time.perf_counter() - self.t0
        jobs = []
        for j in self.jobs:
            r = self.records.get(j["id"], {"status": "not-run", "error": None})
            jobs.append({**describe(j), "status": r["status"], "error": r.get("error"),
                         "seconds": r.get("seconds"), "worker": r.get("worker")})
        report = {"puppet_batch_report": 1, "started": self.started, "finished": now(),
                  "seconds": round(seconds, 3), "cluster": self.cluster, "interrupted": self.interrupted,
                  "counts": counts, "jobs": jobs}
        if self.room is not None:
            report["room"] = self.room
        path = write_report(self.out_dir, report)
        return {"counts": counts, "seconds": seconds, "report": path, "jobs_per_s": ran / seconds if seconds else 0.0}


def threads_warning(workers: dict) -> str | None:
    """A line for the user when workers have more than one thread (``scheduler_info()``'s
    workers): a worker runs one job at a time, in its job runner's thread."""
    wide = sorted(a for a, w in workers.items() if int(w.get("nthreads", 1)) > 1)
    if not wide:
        return None
    n = max(int(workers[a]["nthreads"]) for a in wide)
    return (f"puppet batch: {len(wide)} of {len(workers)} workers have up to {n} threads, but a worker runs one "
            "job at a time: start one worker process per core (dask worker --nthreads 1 --nworkers N)")


def guard(batch: "Batch", reads: list[tuple[str, str]], source: str | None) -> None:
    """The checks of :mod:`puppet.batch.guard` before anything is written (SceneError)."""
    batch.cache = scene_inputs(batch.jobs)
    inputs = all_inputs(batch.jobs, batch.cache, reads)
    check_outputs(batch.jobs, inputs, source)
    check_own_files(batch.out_dir, inputs)
    batch.keep = frozenset(inputs)
    batch.checked = True


def run_batch(jobs: list[dict], out_dir: str, *, workers: int | None = None, scheduler: str | None = None,
              retries: int = 2, resume: bool = False, progress: bool = False, client=None,
              say: Callable[[str], None] = lambda s: None, on_result: Callable | None = None,
              reads: list[tuple[str, str]] = (), source: str | None = None,
              finale: Callable | None = None) -> dict:
    """Run ``jobs`` (see :mod:`puppet.batch.jobs`) on Dask and write ``OUT_DIR/report.json``.

    Parameters
    ----------
    client : a ``distributed.Client`` to use (tests, benchmarks); else one is made on an
        embedded LocalCluster of ``workers`` processes, or on ``scheduler``.
    say : prints a line for the user (the dashboard address).
    reads : (path, what) of files the run reads besides the jobs' scenes and pictures (the
        job list): no output may replace one. source : the file named in command errors.
    finale : ``finale(batch)`` once every job ran (not when stopped), before the report is
        written: what it returns is the report's ``room`` (``--dressroom``).

    Returns
    -------
    dict with ``counts`` (done / failed / no-match / skipped / not-run), ``seconds``,
    ``report`` (its path) and ``jobs_per_s``. A KeyboardInterrupt or the CLI's stop
    exception propagates after OUT_DIR is left consistent (the report written, also when
    it came before the cluster was up).

    Raises
    ------
    SceneError
        An output on a file the run reads, the batch's own files not regular files, a
        scheduler that cannot be reached: nothing is written (the manifest is left as it was).
    """
    batch = Batch(jobs, out_dir, resume=resume, progress=progress)
    reads = list(reads)
    check_own_files(out_dir, {os.path.realpath(p): what for p, what in reads})  # at once: may a report be written
    up = False  # the cluster is there: from then on the manifest is rewritten at the end
    try:
        guard(batch, reads, source)
        todo = batch.plan()
        if client is not None:
            session = contextlib.nullcontext((client, None))
        elif todo:
            session = connect(workers=workers, scheduler=scheduler, retries=retries, say=say)
        else:
            session = contextlib.nullcontext((None, None))
        with session as (c, dashboard):  # a scheduler that cannot be reached: SceneError, nothing written
            up = True
            try:
                if c is not None:
                    _started(batch, c, client, scheduler, dashboard, say)
                    batch.run(c, todo, retries=retries, on_result=on_result)
                if finale is not None:
                    batch.room = finale(batch)
            except BaseException:
                batch.interrupted = True
                raise
            finally:
                summary = batch.finish()
    except SceneError:
        raise  # before the cluster was up (it cannot be reached): nothing written, the manifest kept
    except BaseException:  # Ctrl+C, SIGTERM before the cluster was up: the report still says so
        if not up and (batch.checked or not os.path.lexists(os.path.join(out_dir, "report.json"))):
            batch.interrupted = True
            summary = batch.finish(manifest=False)
        raise
    finally:
        sweep_temporaries(jobs, keep=batch.keep)  # again, once the embedded workers are gone
        if batch.interrupted and "summary" in locals():
            c = summary["counts"]
            say(f"puppet batch: stopped: {c['done']} done, {c['failed'] + c['no-match']} failed, "
                f"{c['not-run']} not run; run it again with --resume to finish the rest")
    return summary


def _started(batch: Batch, c, client, scheduler: str | None, dashboard: str | None, say) -> None:
    info = c.scheduler_info()
    batch.cluster = scheduler or ("given client" if client is not None else f"local, {len(info['workers'])} workers")
    if dashboard:
        say(f"puppet batch: Dask dashboard at {dashboard}")
    warning = threads_warning(info["workers"])
    if warning:
        say(warning)
