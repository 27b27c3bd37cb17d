"""The Dask cluster a batch runs on: an embedded LocalCluster (worker processes, spawned,
one thread each) or an existing cluster's scheduler. Dask's own logging is kept off the
terminal (errors of jobs go to the report instead)."""
from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import signal
import tempfile
import threading
from collections.abc import Iterator

from puppet.anim.options import WORKER_BYTES, default_workers, worker_cap
from puppet.batch.reach import CONNECT_SECONDS, check_scheduler, one_line_failure

#: Logging level of Dask's loggers on the client and in embedded workers (the user's
#: DASK_LOGGING__DISTRIBUTED wins).
DASK_LOG_LEVEL = "critical"
def quiet_dask() -> None:
    """Set before ``distributed`` is imported: spawned workers inherit the environment."""
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", DASK_LOG_LEVEL)
    os.environ.setdefault("DASK_DISTRIBUTED__ADMIN__LOG_LENGTH", "0")
    level = os.environ["DASK_LOGGING__DISTRIBUTED"].upper()
    for name in ("distributed", "tornado", "bokeh", "asyncio"):
        logging.getLogger(name).setLevel(getattr(logging, level, logging.CRITICAL))


def capped_workers(asked: int | None, say) -> int:
    """The embedded cluster's worker count: ``asked`` (default: one per core), at most one per
    core and one per :data:`WORKER_BYTES` of available memory; a cut is said in one line."""
    cap, cores, memory = worker_cap()
    if asked is None:
        return cap
    if asked > cap:
        gib = f", {memory / 2 ** 30:.1f} GiB of memory available" if memory else ""
        say(f"puppet batch: --workers {asked}: starting {cap} ({cores} cores{gib}; a worker runs one job at a "
            f"time on one core and needs up to {WORKER_BYTES / 2 ** 30:.1f} GiB)")
        return cap
    return asked


@contextlib.contextmanager
def connect(*, workers: int | None = None, scheduler: str | None = None, retries: int = 2,
            say=lambda line: None) -> Iterator[tuple]:
    """A ``distributed.Client`` on the embedded cluster or on ``scheduler``.

    Yields
    ------
    (client, dashboard) : the client, and the dashboard address or None (no bokeh).

    ``say`` prints a line for the user (more workers asked than the machine can run).

    Raises
    ------
    SceneError
        The scheduler cannot be reached (one line, within :data:`CONNECT_SECONDS` or so).
    """
    quiet_dask()
    address = None
    if scheduler is not None:
        address = check_scheduler(scheduler)  # before Dask: malformed, refused, silent, not Dask: one line
    # Ctrl+C and SIGHUP are held from before Dask starts its first thread until the client is
    # up: every thread and process Dask starts inherits the block (no worker is interrupted
    # half way through its imports), and a signal that came meanwhile is acted on after
    with contextlib.ExitStack() as held:
        held.enter_context(_sigint_blocked())
        import dask

        with dask.config.set(_settings(retries)):
            if address is not None:
                client = _client(scheduler, address)
                held.close()
                try:
                    yield client, _dashboard(client)
                finally:
                    with contextlib.suppress(Exception):
                        client.close(timeout=10)
                return
            yield from _local(capped_workers(workers, say), held)


def _settings(retries: int) -> dict:
    # Dask's own tasks (the job runners' creation) whose worker dies are retried up to
    # `retries` times; the jobs' retries are counted by the client (puppet/batch/dispatch.py)
    return {"distributed.scheduler.allowed-failures": int(retries),
            "distributed.worker.multiprocessing-method": "spawn",
            "distributed.worker.daemon": False,
            # measured ~8 % slower solves with Dask's malloc trimming in the workers
            # (MALLOC_TRIM_THRESHOLD_=65536); a worker holds a few scenes, not growing data
            "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
            # the statistical profiler samples the task thread every 10 ms: not needed here
            "distributed.worker.profile.enabled": False,
            # Dask's health checks and monitors, made less frequent: idle, a worker used
            # 20 ms of CPU a second and the client process (scheduler, nannies) 35 ms;
            # with these 3 and 6 ms (measured), i.e. less stolen from the jobs
            "distributed.admin.tick.interval": "1s",
            "distributed.admin.system-monitor.interval": "2s",
            "distributed.admin.system-monitor.disk": False,
            "distributed.worker.memory.monitor-interval": "1s",
            "distributed.deploy.cluster-repr-interval": "10s"}


def _local(n: int, held: contextlib.ExitStack) -> Iterator[tuple]:
    """Start the embedded cluster of ``n`` workers, close ``held`` (the signal block) once
    it is up, yield (client, dashboard), close it."""
    import dask
    from distributed import Client, LocalCluster

    # Mesa llvmpipe draws with one thread per core in each worker: as many workers as
    # cores would oversubscribe them. A worker with one core's share draws in its own
    # thread (0: no rasteriser thread; 1 would hand every draw to a second thread and
    # wait: two such workers measured 1.61-1.70x one worker's throughput, with 0
    # 1.82-2.02x). Same pixels with any count; the user's value wins.
    share = default_workers() // n
    lp = {"distributed.nanny.pre-spawn-environ.LP_NUM_THREADS": share if share > 1 else 0}
    # a free port for the scheduler's HTTP server (Dask's default 8787 may be taken);
    # a dashboard only with bokeh installed
    dash = importlib.util.find_spec("bokeh") is not None
    with tempfile.TemporaryDirectory(prefix="puppet-batch-") as scratch:
        cluster = client = None
        environ = dict(os.environ)
        # Dask's own scratch space (dask-scratch-space/*.lock) goes there too, not into $TMPDIR
        lp["temporary-directory"] = scratch
        try:
            with dask.config.set(lp):
                cluster = LocalCluster(n_workers=n, threads_per_worker=1,
                                       processes=True, dashboard_address=":0", local_directory=scratch,
                                       scheduler_port=0, host="127.0.0.1", silence_logs=logging.CRITICAL,
                                       preload=["puppet.batch.preload"])
                client = Client(cluster, set_as_default=False)
            _restore_environ(environ)  # Dask's nannies set their workers' variables in this process too
            held.close()  # a Ctrl+C that came while the cluster started is raised here
            yield client, _dashboard(client) if dash else None
        finally:
            if client is not None:
                with contextlib.suppress(Exception):
                    client.close(timeout=10)
            if cluster is not None:
                with contextlib.suppress(Exception):
                    cluster.close(timeout=20)


def _client(scheduler: str, address: str):
    """A client on an existing scheduler (``address``: checked by :mod:`puppet.batch.reach`)."""
    from distributed import Client

    try:
        return Client(address, timeout=f"{CONNECT_SECONDS}s", set_as_default=False)
    except Exception as e:  # noqa: BLE001 - whatever Dask raises, the user gets one line
        raise one_line_failure(scheduler, e) from None


def _restore_environ(saved: dict[str, str]) -> None:
    for k in set(os.environ) - set(saved):
        os.environ.pop(k, None)
    for k, v in saved.items():
        if os.environ.get(k) != v:
            os.environ[k] = v


#: Signals a terminal sends to the whole process group.
_GROUP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGHUP") if hasattr(signal, n))


@contextlib.contextmanager
def _sigint_blocked():
    """Block Ctrl+C and SIGHUP in this thread while the cluster starts: threads started
    meanwhile inherit the mask, and a signal that arrives is handled after the block (by
    this thread or by one started earlier, never lost). A SIGTERM is acted on after it too.

    multiprocessing's resource tracker is started here, from this thread, so it inherits
    the block and never sees the terminal's hang-up: killed by SIGHUP, it was relaunched by
    the client and printed a traceback for every semaphore it no longer knew."""
    main = threading.current_thread() is threading.main_thread() and hasattr(signal, "pthread_sigmask")
    if not main:
        yield
        return
    # SIGTERM stays unblocked (the nannies stop their workers with it) but its handler waits too
    term, came = signal.getsignal(signal.SIGTERM), []
    if callable(term):
        signal.signal(signal.SIGTERM, lambda signum, frame: came.append((signum, frame)))
    old = signal.pthread_sigmask(signal.SIG_BLOCK, set(_GROUP_SIGNALS))
    try:
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()
        signal.pthread_sigmask(signal.SIG_BLOCK, set(_GROUP_SIGNALS))  # it unblocks SIGINT on its way out
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        if callable(term):
            signal.signal(signal.SIGTERM, term)
            if came:
                term(*came[0])


def _dashboard(client) -> str | None:
    with contextlib.suppress(Exception):
        return client.dashboard_link
    return None

