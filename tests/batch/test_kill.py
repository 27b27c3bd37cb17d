"""A worker process killed in the middle of a job loses no job: its nanny starts a new
worker, which gets a job runner, and the job runs again (up to --retries); no temporary
file is left."""
from __future__ import annotations

import contextlib
import json
import os
import signal
import threading

import pytest

from puppet.batch.jobs import read_job_list
from puppet.batch.runner import run_batch
from tests.batch.conftest import copy_scene, temporaries, write_list

pytestmark = [pytest.mark.gl, pytest.mark.slow]

#: Seconds a killed batch may take before its test fails (such a batch once hung forever:
#: the replacement worker was never given the dead worker's scene).
DEADLINE = 300.0


@contextlib.contextmanager
def deadline(seconds: float = DEADLINE):
    """Fail the test, not hang it, when the batch inside has not ended within ``seconds``
    (SIGALRM, in the main thread; the batch's cluster is closed on the way out)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def expired(signum, frame):
        pytest.fail(f"the batch did not end within {seconds:g} s", pytrace=False)

    old = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _trex_frames(tmp_path, n: int, size: list[int]):
    """(entries, OUT_DIR, jobs): ``n`` T-rex frames 0.1 s apart."""
    scene = os.path.basename(copy_scene("trex-layers.json", tmp_path))
    entries = [{"scene": scene, "time": round(0.1 * k, 2), "size": size, "output": f"f{k:02d}.png"}
               for k in range(n)]
    out = os.path.realpath(tmp_path / "out")
    os.mkdir(out)
    return entries, out, read_job_list(write_list(tmp_path / "jobs.json", entries), out, {"budget": 120.0})


def _kill_once(client, killed: list):
    """An ``on_result`` that SIGKILLs the first busy worker once, recording (address, pid,
    pieces it had)."""
    def kill(batch, recs):
        busy = batch.dispatch.busy()
        if killed or not busy:
            return
        victim = sorted(busy)[0]
        pid = client.run(os.getpid, workers=[victim])[victim]
        os.kill(pid, signal.SIGKILL)
        killed.append((victim, pid, busy[victim]))
    return kill


def test_killing_a_worker_mid_run_loses_no_job(cluster2, tmp_path):
    entries, out, jobs = _trex_frames(tmp_path, 24, [90, 75])
    killed = []
    with deadline():
        summary = run_batch(jobs, out, client=cluster2, retries=2, on_result=_kill_once(cluster2, killed))
    assert killed and killed[0][2], "no worker was busy when results came in"
    report = json.loads(open(summary["report"]).read())
    assert summary["counts"]["done"] == len(entries), [j["error"] for j in report["jobs"] if j["error"]]
    assert all(os.path.isfile(os.path.join(out, e["output"])) for e in entries)
    assert temporaries(out) == []
    manifest = json.loads(open(os.path.join(out, "manifest.json")).read())["outputs"]
    assert sorted(manifest) == sorted(e["output"] for e in entries)
    cluster2.wait_for_workers(2, timeout=120)  # the nanny started a new worker
    assert killed[0][1] not in cluster2.run(os.getpid).values()


def _only_worker_killed(tmp_path, retries: int):
    """16 T-rex frames on a cluster of one worker, killed once mid-run: (entries, OUT_DIR,
    summary, report)."""
    from puppet.batch.cluster import connect

    entries, out, jobs = _trex_frames(tmp_path, 16, [60, 50])
    killed = []
    with deadline(), connect(workers=1, retries=retries) as (client, _):
        summary = run_batch(jobs, out, client=client, retries=retries, on_result=_kill_once(client, killed))
    assert killed
    return entries, out, summary, json.loads(open(summary["report"]).read())


def test_a_job_whose_worker_dies_past_the_retries_is_reported_and_the_batch_goes_on(tmp_path):
    entries, out, summary, report = _only_worker_killed(tmp_path, retries=0)
    died = [j for j in report["jobs"] if j["status"] == "failed"]
    assert died and all("workers running this job died" in j["error"] for j in died), report["jobs"]
    assert summary["counts"]["done"] == len(entries) - len(died)  # the batch went on after it
    assert all(os.path.isfile(os.path.join(out, j["output"])) for j in report["jobs"] if j["status"] == "done")
    assert temporaries(out) == []


def test_the_only_worker_killed_its_queued_pieces_run_on_its_replacement(tmp_path):
    """Pieces are given to a worker ahead of time: when the only one dies, they wait for the
    worker its nanny starts, which gets a job runner of its own."""
    entries, out, summary, report = _only_worker_killed(tmp_path, retries=2)
    assert summary["counts"]["done"] == len(entries), [j["error"] for j in report["jobs"] if j["error"]]
    assert all(os.path.isfile(os.path.join(out, e["output"])) for e in entries)
