"""``puppet batch`` from the shell: exit statuses, Ctrl+C then --resume, and a cluster of
separate processes (``dask scheduler`` + 2 ``dask worker``) giving the same bytes as the
embedded LocalCluster."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from puppet.batch.jobs import read_job_list
from puppet.batch.runner import run_batch
from tests.batch.conftest import copy_scene, temporaries, write_bar, write_list
from tests.conftest import ROOT

pytestmark = [pytest.mark.gl, pytest.mark.slow]
DASK = os.path.join(os.path.dirname(sys.executable), "dask")


def _puppet(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "puppet", "batch", *map(str, args)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _outputs(folder) -> dict[str, bytes]:
    found = {}
    for d, _, files in os.walk(folder):
        for n in files:
            if n not in ("report.json", "manifest.json"):
                p = os.path.join(d, n)
                found[os.path.relpath(p, folder)] = open(p, "rb").read()
    return found


def test_interrupted_then_resumed_from_the_shell(tmp_path):
    scene = os.path.basename(copy_scene("trex-layers.json", tmp_path))
    write_bar(tmp_path)
    entries = [{"scene": scene, "time": round(0.08 * k, 2), "size": [120, 100], "output": f"t/{k:02d}.png"}
               for k in range(24)]
    entries += [{"scene": "bar.json", "pose": "bend", "output": "bend.png"},
                {"scene": "bar.json", "pose": "missing", "output": "missing.png"}]
    lst = write_list(tmp_path / "jobs.json", entries)
    out = tmp_path / "out"
    p = _puppet(lst, "-o", out, "--workers", "2", start_new_session=True)
    manifest = out / "manifest.json"
    deadline = time.time() + 240
    while time.time() < deadline and p.poll() is None:
        if manifest.exists() and json.loads(manifest.read_text() or "{}").get("outputs"):
            break
        time.sleep(0.05)
    assert p.poll() is None, p.communicate()
    os.killpg(p.pid, signal.SIGINT)  # what Ctrl+C in a terminal sends: the whole process group
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert "Traceback" not in err and "puppet: interrupted" in err and "--resume" in err, err
    assert temporaries(out) == []
    done = json.loads(manifest.read_text())["outputs"]
    assert done and all((out / rel).is_file() for rel in done)
    report = json.loads((out / "report.json").read_text())
    assert report["interrupted"] is True and report["counts"]["not-run"] > 0

    p = _puppet(lst, "-o", out, "--workers", "2", "--resume")
    stdout, err = p.communicate(timeout=300)
    assert p.returncode == 3, err  # finished, but one job asks for a pose the scene lacks
    assert "Traceback" not in err
    report = json.loads((out / "report.json").read_text())
    by = {j["output"]: j for j in report["jobs"]}
    assert {o for o, j in by.items() if j["status"] == "skipped"} == set(done)
    assert report["counts"]["done"] == len(entries) - len(done) - 1
    assert by["missing.png"]["status"] == "failed" and "no pose named 'missing'" in by["missing.png"]["error"]
    assert f"{len(entries)} jobs: {report['counts']['done']} done, 1 failed, {len(done)} up to date" in stdout
    assert temporaries(out) == [] and sorted(_outputs(out)) == sorted(e["output"] for e in entries[:-1])


@pytest.fixture
def separate_cluster(tmp_path):
    """A scheduler and 2 workers, each its own process started from the shell."""
    procs = []
    log = open(tmp_path / "dask.log", "w")
    try:
        file = tmp_path / "scheduler.json"
        procs.append(subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                       "--scheduler-file", str(file)], stdout=log, stderr=log, cwd=tmp_path))
        deadline = time.time() + 60
        while not file.exists() and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(0.2)
        address = json.loads(file.read_text())["address"]
        for i in range(2):
            procs.append(subprocess.Popen([DASK, "worker", address, "--nthreads", "1", "--no-dashboard",
                                           "--local-directory", str(tmp_path / f"w{i}")],
                                          stdout=log, stderr=log, cwd=tmp_path))
        from distributed import Client

        with Client(address, set_as_default=False) as c:
            c.wait_for_workers(2, timeout=120)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()


def test_separate_process_cluster_matches_the_local_cluster(cluster2, separate_cluster, tmp_path):
    write_bar(tmp_path)
    scene = os.path.basename(copy_scene("dress-garment.json", tmp_path))
    entries = [{"scene": scene, "pose": p, "size": [100, 100], "output": f"dress/{p}.png"}
               for p in ("rest", "flare", "sway", "twirl")]
    entries += [{"scene": scene, "time": 0.3, "output": "dress/t.png"},
                {"scene": "bar.json", "animate": {"fps": 5}, "output": "bar.gif"},
                {"scene": "bar.json", "animate": {"fps": 5}, "output": "frames/"},
                {"scene": "bar.json", "pose": "bend", "wireframe": True, "output": "wire.png"}]
    lst = write_list(tmp_path / "jobs.json", entries)
    local = os.path.realpath(tmp_path / "local")
    os.mkdir(local)
    s = run_batch(read_job_list(lst, local, {"budget": 120.0}), local, client=cluster2)
    assert s["counts"]["done"] == len(entries)

    p = _puppet(lst, "-o", tmp_path / "remote", "--scheduler", separate_cluster)
    stdout, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    report = json.loads((tmp_path / "remote" / "report.json").read_text())
    assert report["cluster"] == separate_cluster and report["counts"]["done"] == len(entries)
    a, b = _outputs(local), _outputs(tmp_path / "remote")
    assert sorted(a) == sorted(b) and len(a) == len(entries) - 1 + 6  # the folder holds 6 frames
    assert [k for k in a if a[k] != b[k]] == []


def test_unreachable_scheduler_is_one_line(tmp_path):
    write_bar(tmp_path)
    lst = write_list(tmp_path / "jobs.json", [{"scene": "bar.json"}])
    p = _puppet(lst, "-o", tmp_path / "out", "--scheduler", "tcp://127.0.0.1:9")
    _, err = p.communicate(timeout=120)
    assert p.returncode == 2 and err.startswith("puppet: error: --scheduler 'tcp://127.0.0.1:9': cannot connect"), err
    assert err.count("\n") == 1
    assert not (tmp_path / "out").exists()
