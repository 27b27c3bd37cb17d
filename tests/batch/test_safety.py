"""``puppet batch`` never destroys a file, hangs or answers with a traceback (issue 20), through
the real command line: each case checks the exit status, one ``puppet: error:`` line, the
files byte-identical before and after, nothing left behind, under a timeout.

Most cases are refused before a cluster starts (fast); the cases that need workers share
one run (:func:`test_resume_after_tampering_runs_once_with_workers_capped`)."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from tests.batch.conftest import write_bar, write_list
from tests.fstree import digest, snapshot


def batch(*args, cwd, timeout=60, env=None, **kw) -> tuple[int, str]:
    p = subprocess.run([sys.executable, "-m", "puppet", "batch", *map(str, args)], cwd=cwd, capture_output=True,
                       text=True, timeout=timeout, env=env, **kw)
    return p.returncode, p.stderr


def one_error(rc: int, err: str, *words: str) -> None:
    assert rc == 2, err
    assert err.startswith("puppet: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def refused(tmp_path, entries_or_list, *words, out="out", extra=()):
    """Run a list that must be refused before anything runs: exit 2, one line, nothing changed."""
    lst = entries_or_list if isinstance(entries_or_list, str) else write_list(tmp_path / "jobs.json", entries_or_list)
    before = snapshot(tmp_path)
    rc, err = batch(lst, "-o", out, *extra, cwd=tmp_path, timeout=60)
    one_error(rc, err, *words)
    assert snapshot(tmp_path) == before
    return err


# -- the batch's own files ------------------------------------------------------------
@pytest.mark.parametrize("name", ["manifest.json", "report.json"])
def test_own_file_that_is_a_symlink_is_never_written_through(tmp_path, name):
    write_bar(tmp_path)
    (tmp_path / "out").mkdir()
    os.symlink(tmp_path / "bar.json", tmp_path / "out" / name)  # would have replaced the scene by JSON
    refused(tmp_path, [{"scene": "bar.json"}], f"out/{name}", "symbolic link")


def test_fifo_manifest_is_refused_without_hanging(tmp_path):
    write_bar(tmp_path)
    (tmp_path / "out").mkdir()
    os.mkfifo(tmp_path / "out" / "manifest.json")
    refused(tmp_path, [{"scene": "bar.json"}], "manifest.json", "not a regular file", extra=["--resume"])


def test_job_list_inside_out_dir_named_manifest_is_refused(tmp_path):
    write_bar(tmp_path)
    (tmp_path / "out").mkdir()
    lst = write_list(tmp_path / "out" / "manifest.json", [{"scene": "../bar.json"}])
    refused(tmp_path, lst, "manifest.json", "the job list")


# -- outputs on inputs ------------------------------------------------------------------
def test_output_on_another_jobs_input_is_refused(tmp_path):
    write_bar(tmp_path / "trex", name="trex.json", image="Body.PNG")
    write_bar(tmp_path)
    # job 0 writes the image job 1's scene reads (-o .): only a job's own inputs were protected
    err = refused(tmp_path, [{"scene": "bar.json", "output": "trex/Body.PNG"}, {"scene": "trex/trex.json"}],
                  "job 0", "trex/Body.PNG", "layers[0].image", out=".")
    assert "a frame goes to a .png" not in err


def test_folder_output_holding_another_scenes_images_is_refused(tmp_path):
    write_bar(tmp_path / "imgs", name="a.json", image="frame_00000.png")  # named like a frame: it would go
    write_bar(tmp_path)
    refused(tmp_path, [{"scene": "bar.json", "animate": True, "output": "imgs/"}, {"scene": "imgs/a.json"}],
            "job 0", "imgs/", out=".")


def test_output_on_the_job_list_or_a_scene_is_refused(tmp_path):
    write_bar(tmp_path, name="s.png", image="i.png")  # a scene file with a .png name
    refused(tmp_path, [{"scene": "s.png", "output": "s.png"}], "the scene file", out=".")
    (tmp_path / "sub").mkdir()
    lst = write_list(tmp_path / "sub" / "jobs.json", [{"scene": "../s.png", "animate": True, "output": "sub/"}])
    refused(tmp_path, lst, "the job list", out=".")


def test_output_through_a_link_inside_out_dir_is_refused(tmp_path):
    write_bar(tmp_path)
    (tmp_path / "out" / "real").mkdir(parents=True)
    os.symlink("real", tmp_path / "out" / "link")
    refused(tmp_path, [{"scene": "bar.json", "output": "link/x.png"}], "symbolic link", "'link'")


# -- job lists that hung, filled memory or gave a traceback -------------------------------
def _fifo(path):
    os.mkfifo(path)
    return str(path)


@pytest.mark.parametrize("make, words", [
    (_fifo, ["not a regular file"]),
    (lambda p: os.symlink("/dev/zero", p) or str(p), ["not a regular file"]),
    (lambda p: p.write_text("[" * 100_000) and str(p), ["nested deeper"]),
    (lambda p: p.write_text('[{"scene": "bar.json", "time": ' + "9" * 5000 + "}]") and str(p), ["too large"]),
    (lambda p: p.write_text('[{"scene": "bar.json", "output": "a\\u0000.png"}]') and str(p), ["control character"]),
    (lambda p: p.write_text('[{"scene": "b\\u0000.json"}]') and str(p), ["NUL"]),
    (lambda p: p.write_text('[{"scene": "bar.json", "animate": {"fps": 0}}]') and str(p), ["fps 0", "0.01..240"]),
    (lambda p: p.write_text('[{"scene": "bar.json", "time": 1e400}]') and str(p), ["too large"]),
])
def test_bad_job_lists_are_one_line(tmp_path, make, words):
    write_bar(tmp_path)
    lst = make(tmp_path / "jobs.json")
    refused(tmp_path, lst, "jobs.json", *words)


def test_deep_jsonl_line_is_one_line(tmp_path):
    write_bar(tmp_path)
    (tmp_path / "jobs.jsonl").write_text('{"scene": "bar.json"}\n' + "[" * 100_000 + "\n")
    refused(tmp_path, str(tmp_path / "jobs.jsonl"), "line 2", "nested deeper")


# -- schedulers ---------------------------------------------------------------------------
class FakeServer:
    """A TCP server on a free port that accepts and then stays silent, or answers ``answer``
    (and hangs up at once with ``close``). Also used by tests/safety/campaign_batch.py."""

    def __init__(self, answer: bytes | None, close: bool = False):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.answer, self.hang_up, self.conns = answer, close, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                c, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(c)
            try:
                if self.answer:
                    c.sendall(self.answer)
                if self.hang_up:
                    c.close()
            except OSError:
                pass

    def close(self):
        for c in self.conns:
            c.close()
        self.sock.close()


@pytest.mark.parametrize("address, words", [
    ("", ["not a scheduler address"]),
    ("not an address", ["not a scheduler address"]),
    ("inproc://x", ["not a scheduler address"]),
    ("ucx://127.0.0.1:8786", ["ucx:// is not supported"]),
    ("tcp://127.0.0.1:99999", ["not a port"]),
    ("tcp://127.0.0.1:9", ["cannot connect"]),
    pytest.param("silent", ["does not answer"], marks=pytest.mark.slow),  # waits reach.CONNECT_SECONDS (5 s) for an answer
    ("garbage", ["not like a Dask scheduler"]),
    ("huge", ["not like a Dask scheduler"]),
])
def test_unreachable_schedulers_fail_in_one_line_and_keep_the_manifest(tmp_path, address, words):
    write_bar(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "manifest.json").write_text('{"puppet_batch_manifest": 1, "outputs": {"bar/rest.png": '
                                       '{"inputs": "x", "finished": "2026"}}}\n')
    server = None
    if address in ("silent", "garbage", "huge"):
        answer = {"silent": None, "garbage": b"HTTP/1.0 200 OK\r\n\r\nhello\n" * 4,
                  "huge": (2 ** 40).to_bytes(8, "little")}[address]  # a length Dask would allocate
        server = FakeServer(answer)
        address = f"tcp://127.0.0.1:{server.port}"
    try:
        t0 = time.monotonic()
        refused(tmp_path, [{"scene": "bar.json"}], *words, extra=["--scheduler", address])
        assert time.monotonic() - t0 < 30
    finally:
        if server:
            server.close()


def test_unreachable_scheduler_leaves_no_out_dir(tmp_path):
    write_bar(tmp_path)
    lst = write_list(tmp_path / "jobs.json", [{"scene": "bar.json"}])
    rc, err = batch(lst, "-o", "new", "--scheduler", "tcp://127.0.0.1:9", cwd=tmp_path)
    one_error(rc, err, "cannot connect")
    assert not (tmp_path / "new").exists()


# -- runs with workers (one cluster each) ------------------------------------------------------
def _hand_manifest(tmp_path, lst, out) -> None:
    """The manifest a finished run would leave, with each output in place (no cluster needed)."""
    from puppet.batch.jobs import read_job_list
    from puppet.batch.runner import client_digest

    jobs, cache, entries = read_job_list(str(lst), str(out), {}), {}, {}
    for j in jobs:
        os.makedirs(os.path.dirname(j["output"]), exist_ok=True)
        with open(j["output"], "wb") as f:
            f.write(b"an earlier output of " + j["rel"].encode())
        entries[j["rel"]] = {"inputs": client_digest(j, cache), "finished": "2026-11-26T00:00:00+00:00"}
    (out / "manifest.json").write_text(json.dumps({"puppet_batch_manifest": 1, "outputs": entries}))


@pytest.mark.gl
@pytest.mark.slow
def test_resume_after_tampering_runs_once_with_workers_capped(tmp_path):
    for name in "abcde":
        write_bar(tmp_path, name=f"{name}.json", image=f"{name}.png")
    lst = write_list(tmp_path / "jobs.json", [{"scene": f"{n}.json", "output": f"{n}.png"} for n in "abcde"])
    out = tmp_path / "out"
    _hand_manifest(tmp_path, lst, out)
    for name, target in (("a", "/dev/zero"), ("b", "/dev/urandom")):
        os.remove(tmp_path / f"{name}.png")
        os.symlink(target, tmp_path / f"{name}.png")  # was hashed without a regular-file check: hung
    os.remove(tmp_path / "c.png")
    os.mkfifo(tmp_path / "c.png")
    os.remove(out / "d.png")
    (out / "d.png").mkdir()  # an output that became a folder is not "done"
    (out / "d.png" / "keep.txt").write_text("mine")
    before = {k: v for k, v in snapshot(tmp_path).items() if not k.startswith("out/") or k.startswith("out/d.png")}
    scratch = tmp_path.parent / f"{tmp_path.name}-tmp"
    scratch.mkdir()
    env = dict(os.environ, TMPDIR=str(scratch))
    rc, err = batch(lst, "-o", out, "--resume", "--workers", "64", cwd=tmp_path, timeout=300, env=env)
    assert rc == 3 and "Traceback" not in err, err
    assert err.startswith("puppet batch: --workers 64: starting ") and err.count("\n") == 1, err
    report = json.loads((out / "report.json").read_text())
    status = {j["output"]: (j["status"], j["error"]) for j in report["jobs"]}
    assert status["e.png"] == ("skipped", None)
    assert all(status[f"{n}.png"][0] == "failed" for n in "abcd"), status
    assert "folder" in status["d.png"][1]
    after = snapshot(tmp_path)
    assert {k: after[k] for k in before} == before
    kept = b"an earlier output of e.png"
    assert after["out/e.png"] == ("file", digest(kept), len(kept))
    assert os.listdir(scratch) == []  # no dask-scratch-space/*.lock left in $TMPDIR


def _stopped(tmp_path, sig, when: str):
    write_bar(tmp_path)
    lst = write_list(tmp_path / "jobs.json", [{"scene": "bar.json", "time": round(0.01 * k, 2), "size": [400, 300],
                                               "output": f"t/{k:03d}.png"} for k in range(150)])
    out = tmp_path / "out"
    out.mkdir()
    (out / "manifest.json").write_text('{"puppet_batch_manifest": 1, "outputs": {}}\n')
    p = subprocess.Popen([sys.executable, "-m", "puppet", "batch", lst, "-o", out, "--workers", "1"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 240
    ready = (lambda: (out / "t").exists()) if when == "running" else (lambda: True)
    while time.time() < deadline and p.poll() is None and not ready():
        time.sleep(0.02)
    time.sleep(0.8 if when == "start" else 0)
    assert p.poll() is None, p.communicate()
    os.killpg(p.pid, sig)
    _, err = p.communicate(timeout=120)
    return p.returncode, err, out


@pytest.mark.gl
@pytest.mark.slow
def test_ctrl_c_in_the_first_second_leaves_a_report_and_the_manifest(tmp_path):
    rc, err, out = _stopped(tmp_path, signal.SIGINT, "start")
    assert rc in (130, -signal.SIGINT) and "Traceback" not in err, err
    assert err.splitlines()[-1] == "puppet: interrupted", err
    report = json.loads((out / "report.json").read_text())
    assert report["interrupted"] is True and report["counts"]["not-run"] >= 1
    if report["counts"]["done"] == 0:  # stopped before anything ran: the manifest is as it was
        assert (out / "manifest.json").read_text() == '{"puppet_batch_manifest": 1, "outputs": {}}\n'


@pytest.mark.gl
@pytest.mark.slow
def test_sighup_to_the_process_group_is_one_line(tmp_path):
    rc, err, out = _stopped(tmp_path, signal.SIGHUP, "running")
    assert rc == -signal.SIGHUP and "Traceback" not in err and "resource_tracker" not in err, err
    assert err.splitlines()[-1] == "puppet: stopped by SIGHUP", err
    assert json.loads((out / "report.json").read_text())["interrupted"] is True


# -- puppet video --anchors: read like a job list ------------------------------------------------
@pytest.mark.parametrize("content, words", [
    (None, ["no such --anchors file"]),
    ('{"\\u00b2": {}}', ["expected a frame number"]),
    ('{"' + "9" * 5000 + '": {}}', ["expected a frame number"]),
    ("{" * 100_000, ["nested deeper"]),
    ("fifo", ["not a regular file"]),
])
def test_anchors_files_are_one_line(tmp_path, content, words):
    write_bar(tmp_path)
    anchors = tmp_path / "anchors.json"
    if content == "fifo":
        os.mkfifo(anchors)
    elif content is not None:
        anchors.write_text(content)
    before = snapshot(tmp_path)
    p = subprocess.run([sys.executable, "-m", "puppet", "video", "bar.json", "--pose", "rest", "-o", "v.mp4",
                        "--anchors", "anchors.json"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    one_error(p.returncode, p.stderr, "anchors.json", *words)
    assert snapshot(tmp_path) == before


def test_worker_refuses_a_folder_that_became_a_link_after_the_check(tmp_path):
    from puppet.batch.guard import output_present, unchanged_path

    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    (tmp_path / "elsewhere").mkdir()
    target = str(out / "a" / "x.png")
    assert unchanged_path(target) is None
    (out / "a").rmdir()
    os.symlink(tmp_path / "elsewhere", out / "a")  # swapped in after the client resolved the output
    assert "symbolic link" in unchanged_path(target)
    assert not output_present({"output": target})
    (tmp_path / "elsewhere" / "x.png").write_bytes(b"x")
    assert not output_present({"output": str(out / "a") + os.sep})  # a link is not the frame folder
