"""Attack ``puppet batch`` (and ``puppet video --anchors``) the way a careless or hostile user
could, each case in its own temporary folder, under a timeout and a memory cap, comparing
every file before and after. A script, not a test module (pytest does not collect it)::

    .venv/bin/python tests/safety/campaign_batch.py [--fast] [--only SUBSTRING] [-v]

Prints one line per case and the counts: cases, tracebacks, hangs, inputs modified, writes
outside -o, error messages that are not one line, temporaries left behind, stray stderr
lines (warnings of Dask or multiprocessing), unexpected exit statuses. ``--against DIR``
runs an older checkout (``git archive REV | tar -x -C DIR``) through the same cases. ``--fast`` leaves out the cases that start a Dask cluster.

Each case's folder holds ``in/`` (scenes, images, the job list), ``out/`` (OUT_DIR, unless the
case writes with ``-o in``), ``outside/`` (files nobody should touch) and ``tmp/`` (the run's
$TMPDIR, which must stay empty). A change to anything that existed before, other than the
batch's own report/manifest and what the case declares it may replace, counts as an input
modified; anything new outside OUT_DIR counts as a write outside -o.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import signal
import sys
import tempfile
import time
from dataclasses import dataclass, field

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)

from tests.batch.conftest import write_bar  # noqa: E402
from tests.batch.test_safety import FakeServer as Server  # noqa: E402
from tests.fstree import snapshot  # noqa: E402
from tests.safety.child import run_child  # noqa: E402

MEMORY_CAP = 8 * 2 ** 30  # address space per process (inherited by the workers)
FAST_TIMEOUT, CLUSTER_TIMEOUT = 60, 300


@dataclass
class Case:
    name: str
    setup: object  # f(folder) -> list of extra arguments after "puppet"
    expect: tuple = (2,)  # exit statuses that are right
    cluster: bool = False
    may_change: tuple = ()  # paths (relative to the case folder) the run may replace
    signal_after: tuple | None = None  # (signal, seconds) sent to the process group
    out: str = "out"


@dataclass
class Result:
    case: Case
    rc: int | None = None
    seconds: float = 0.0
    flags: list = field(default_factory=list)
    err: str = ""


# -- helpers for setting up cases ------------------------------------------------------
def jobs(folder: str, entries, name: str = "jobs.json") -> str:
    path = os.path.join(folder, "in", name)
    with open(path, "w") as f:
        json.dump(entries, f)
    return path


def text(folder: str, content, name: str = "jobs.json") -> str:
    path = os.path.join(folder, "in", name)
    with open(path, "wb") as f:
        f.write(content if isinstance(content, bytes) else content.encode())
    return path


def link(folder: str, target: str, name: str) -> str:
    path = os.path.join(folder, name)
    os.symlink(target, path)
    return path


def fifo(folder: str, name: str) -> str:
    path = os.path.join(folder, name)
    os.mkfifo(path)
    return path


def batch_args(folder: str, lst: str, *extra, out: str = "out") -> list[str]:
    return ["batch", lst, "-o", os.path.join(folder, out), *map(str, extra)]


def one_job(folder: str, **job) -> str:
    return jobs(folder, [dict({"scene": "bar.json"}, **job)])


SERVERS: list[Server] = []


def server_address(answer, close=False) -> str:
    s = Server(answer, close)
    SERVERS.append(s)
    return f"tcp://127.0.0.1:{s.port}"


# -- the cases ------------------------------------------------------------------------------
def own_file_cases() -> list[Case]:
    cases = []
    for name in ("manifest.json", "report.json"):
        for what, target in (("the scene", "../in/bar.json"), ("the job list", "../in/jobs.json"),
                             ("an image", "../in/bar.png"), ("outside", "../outside/keep.txt"),
                             ("/dev/null", "/dev/null"), ("dangling", "../outside/none.json"),
                             ("inside", "other.json")):
            def setup(f, name=name, target=target):
                lst = one_job(f)
                link(f, target, f"out/{name}")
                return batch_args(f, lst)
            cases.append(Case(f"{name} is a symlink to {what}", setup))
        for what, make in (("a FIFO", fifo), ("a folder", lambda f, n: os.mkdir(os.path.join(f, n)))):
            def setup(f, name=name, make=make):
                lst = one_job(f)
                make(f, f"out/{name}")
                return batch_args(f, lst, "--resume")
            cases.append(Case(f"{name} is {what}", setup))

    def list_named_manifest(f):
        lst = jobs(f, [{"scene": "../in/bar.json"}])
        os.rename(lst, os.path.join(f, "out", "manifest.json"))
        return batch_args(f, os.path.join(f, "out", "manifest.json"))
    cases.append(Case("the job list is OUT_DIR/manifest.json", list_named_manifest))
    return cases


def job_list_cases() -> list[Case]:
    def make(content, name="jobs.json"):
        return lambda f: batch_args(f, text(f, content, name))

    def linked(target, name="jobs.json"):
        return lambda f: batch_args(f, link(f, target, f"in/{name}"))

    def sparse(f):
        path = os.path.join(f, "in", "jobs.json")
        with open(path, "wb") as fh:
            fh.truncate(70 * 2 ** 20)
        return batch_args(f, path)

    bar = '{"scene": "bar.json"'
    return [
        Case("job list is a FIFO", lambda f: batch_args(f, fifo(f, "in/jobs.json"))),
        Case("job list -> /dev/zero", linked("/dev/zero")),
        Case("job list -> /dev/urandom", linked("/dev/urandom")),
        Case("job list -> /dev/null", linked("/dev/null")),
        Case("job list -> /proc/self/mem", linked("/proc/self/mem")),
        Case("job list .jsonl -> /dev/zero", linked("/dev/zero", "jobs.jsonl")),
        Case("job list 70 MB sparse", sparse),
        Case("job list nested 100000", make("[" * 100_000)),
        Case("job list nested 100000 (objects)", make('{"jobs":' * 100_000)),
        Case("job list nested 33 in a job", make(f"[{bar}, \"size\": " + "[" * 33 + "]" * 33 + "}]")),
        Case("jsonl line nested 100000", make(f"{bar}}}\n" + "[" * 100_000 + "\n", "jobs.jsonl")),
        Case("5000-digit time", make(f"[{bar}, \"time\": {'9' * 5000}}}]")),
        Case("5000-digit size", make(f"[{bar}, \"size\": [{'9' * 5000}, 1]}}]")),
        Case("2^60 budget", make(f"[{bar}, \"budget\": {2 ** 60}}}]")),
        Case("1e400 time", make(f"[{bar}, \"time\": 1e400}}]")),
        Case("NaN time", make(f"[{bar}, \"time\": NaN}}]")),
        Case("-Infinity budget", make(f"[{bar}, \"budget\": -Infinity}}]")),
        Case("duplicate key", make(f"[{bar}, \"pose\": \"rest\", \"pose\": \"bend\"}}]")),
        Case("NUL in output", make(f"[{bar}, \"output\": \"a\\u0000.png\"}}]")),
        Case("newline in output", make(f"[{bar}, \"output\": \"a\\nb.png\"}}]")),
        Case("NUL in scene", make('[{"scene": "bar\\u0000.json"}]')),
        Case("NUL in pose", make(f"[{bar}, \"pose\": \"re\\u0000st\"}}]")),
        Case("300-char output name", make(f"[{bar}, \"output\": \"{'a' * 300}.png\"}}]"), expect=(3,), cluster=True),
        Case("not UTF-8", make(b"[\xff\xfe]")),
        Case("binary garbage", make(os.urandom(4096))),
        Case("empty list", make("[]")),
        Case("jobs is a deep object", make('{"jobs": ' + "{" * 40 + "}" * 40 + "}")),
        Case("a scene given as the job list", lambda f: batch_args(f, os.path.join(f, "in", "bar.json"))),
        Case("missing job list", lambda f: batch_args(f, os.path.join(f, "in", "none.json"))),
        Case("animate fps 0", make(f"[{bar}, \"animate\": {{\"fps\": 0}}}}]")),
        Case("animate fps -1", make(f"[{bar}, \"animate\": {{\"fps\": -1}}}}]")),
        Case("animate fps 1e9", make(f"[{bar}, \"animate\": {{\"fps\": 1e9}}}}]")),
        Case("animate fps 241", make(f"[{bar}, \"animate\": {{\"fps\": 241}}}}]")),
        Case("animate fps string", make(f"[{bar}, \"animate\": {{\"fps\": \"x\"}}}}]")),
        Case("animate from -1", make(f"[{bar}, \"animate\": {{\"from\": -1}}}}]")),
        Case("size 0x10", make(f"[{bar}, \"size\": [0, 10]}}]")),
        Case("size 99999x99999", make(f"[{bar}, \"size\": \"99999x99999\"}}]")),
        Case("size 1e400", make(f"[{bar}, \"size\": [1e400, 1]}}]")),
        Case("budget 0", make(f"[{bar}, \"budget\": 0}}]")),
        Case("unknown key", make(f"[{bar}, \"colour\": 1}}]")),
        Case("scene is a FIFO", lambda f: (fifo(f, "in/pipe.json"),
                                           batch_args(f, jobs(f, [{"scene": "pipe.json"}])))[1],
             expect=(3,), cluster=True),
    ]


def output_cases() -> list[Case]:
    def out_is_in(entries, *extra):
        def setup(f):
            write_bar(os.path.join(f, "in", "trex"), name="trex.json", image="Body.PNG")
            return batch_args(f, jobs(f, entries), *extra, out="in")
        return setup

    def through_link(target, rel):
        def setup(f):
            os.makedirs(os.path.join(f, "out", "real"), exist_ok=True)
            link(f, target, "out/lnk")
            return batch_args(f, one_job(f, output=rel))
        return setup

    def folder_mode_out_in(f):
        return ["batch", os.path.join(f, "in"), "-o", os.path.join(f, "in")]

    def folder_mode_parent(f):
        os.makedirs(os.path.join(f, "in", "bar"))  # the scene's image is in/bar/rest.png: job bar/rest.png's output
        write_bar(os.path.join(f, "in", "scenes"), image="../bar/rest.png")
        return ["batch", os.path.join(f, "in", "scenes"), "-o", os.path.join(f, "in"), "--size", "8x8"]

    def template_on_image(f):
        os.makedirs(os.path.join(f, "in", "imgs"))
        shutil.copy(os.path.join(f, "in", "bar.png"), os.path.join(f, "in", "imgs", "bar.png"))
        return ["batch", "--template", os.path.join(f, "in", "bar.json"), "--images", os.path.join(f, "in", "imgs"),
                "--pose", "bend", "-o", os.path.join(f, "in", "imgs")]

    return [
        Case("output on another job's image (-o in)",
             out_is_in([{"scene": "bar.json", "output": "trex/Body.PNG"}, {"scene": "trex/trex.json"}]), out="in"),
        Case("output on its own image (-o in)", out_is_in([{"scene": "bar.json", "output": "bar.png"}]), out="in"),
        Case("folder output holding another scene (-o in)",
             out_is_in([{"scene": "bar.json", "animate": True, "output": "trex/"}, {"scene": "trex/trex.json"}]),
             out="in"),
        Case("folder output holding the job list (-o in)",
             out_is_in([{"scene": "bar.json", "animate": True, "output": "./"}]), out="in"),
        Case("output on the scene file (-o in)",
             out_is_in([{"scene": "trex/trex.json", "output": "trex/trex.json"}]), out="in"),
        Case("output through a link inside OUT_DIR", through_link("real", "lnk/x.png")),
        Case("output through a link to outside", through_link("../outside", "lnk/x.png")),
        Case("output is a link to an input", through_link("../in/bar.png", "lnk")),
        Case("output ../x.png", lambda f: batch_args(f, one_job(f, output="../x.png"))),
        Case("output absolute", lambda f: batch_args(f, one_job(f, output=os.path.join(f, "outside", "x.png")))),
        Case("output report.json", lambda f: batch_args(f, one_job(f, output="a/../report.json"))),
        Case("output manifest.json", lambda f: batch_args(f, one_job(f, output="./manifest.json"))),
        Case("two jobs one output", lambda f: batch_args(f, jobs(f, [{"scene": "bar.json", "output": "a.png"},
                                                                    {"scene": "bar.json", "output": "./a.png"}]))),
        Case("folder mode -o the folder", folder_mode_out_in),
        Case("folder mode: output on the scene's own image", folder_mode_parent, out="in"),
        Case("template mode -o the images folder", template_on_image, out="in/imgs"),
        Case("OUT_DIR is a file", lambda f: batch_args(f, one_job(f), out="outside/keep.txt")),
        Case("OUT_DIR under /proc", lambda f: ["batch", one_job(f), "-o", "/proc/self/x"]),
    ]


def scheduler_cases() -> list[Case]:
    def sched(address, manifest=True):
        def setup(f):
            if manifest:
                with open(os.path.join(f, "out", "manifest.json"), "w") as fh:
                    fh.write('{"puppet_batch_manifest": 1, "outputs": '
                             '{"bar/rest.png": {"inputs": "x", "finished": "0"}}}\n')
            a = address() if callable(address) else address
            return batch_args(f, one_job(f), "--scheduler", a)
        return setup

    return [Case(f"--scheduler {name}", sched(a)) for name, a in (
        ("''", ""), ("' '", " "), ("not an address", "not an address"), ("inproc://x", "inproc://x"),
        ("ucx://", "ucx://127.0.0.1:8786"), ("ws://", "ws://127.0.0.1:8786"), ("port 0", "tcp://127.0.0.1:0"),
        ("port 70000", "tcp://127.0.0.1:70000"), ("refused", "tcp://127.0.0.1:9"), ("refused ::1", "tcp://[::1]:9"),
        ("tls refused", "tls://127.0.0.1:9"), ("bare host:port", "127.0.0.1:9"),
        ("unknown host", "tcp://no-such-host.invalid:8786"), ("unroutable", "tcp://10.255.255.1:8786"),
        ("silent server", lambda: server_address(None)),
        ("garbage server", lambda: server_address(b"HTTP/1.0 200 OK\r\n\r\n" * 8)),
        ("huge length", lambda: server_address((2 ** 40).to_bytes(8, "little"))),
        ("plausible length then silence", lambda: server_address((60).to_bytes(8, "little"))),
        ("closes at once", lambda: server_address(None, close=True)),
        ("5000-digit port", "tcp://127.0.0.1:" + "9" * 5000),
    )] + [
        Case("--scheduler with --workers", lambda f: batch_args(f, one_job(f), "--scheduler", "tcp://127.0.0.1:9",
                                                                "--workers", "2")),
    ]


def flag_cases() -> list[Case]:
    return [Case(f"--workers {w}", lambda f, w=w: batch_args(f, one_job(f), "--workers", w))
            for w in ("0", "-1", "1025", "9" * 5000, "two")] + [
        Case("--retries -1", lambda f: batch_args(f, one_job(f), "--retries", "-1")),
        Case("--budget nan", lambda f: batch_args(f, one_job(f), "--budget", "nan")),
        Case("--size 0x0", lambda f: batch_args(f, one_job(f), "--size", "0x0")),
        Case("--template without --images", lambda f: ["batch", "--template", os.path.join(f, "in", "bar.json"),
                                                       "-o", os.path.join(f, "out")]),
    ]


def anchors_cases() -> list[Case]:
    def video(make):
        def setup(f):
            anchors = make(f)
            return ["video", os.path.join(f, "in", "bar.json"), "--pose", "rest", "-o",
                    os.path.join(f, "out", "v.mp4"), "--anchors", anchors]
        return setup

    def write(content):
        return lambda f: text(f, content, "anchors.json")

    return [
        Case("--anchors missing", video(lambda f: os.path.join(f, "in", "none.json"))),
        Case("--anchors key ²", video(write('{"\\u00b2": {}}'))),
        Case("--anchors key 5000 digits", video(write('{"' + "9" * 5000 + '": {}}'))),
        Case("--anchors nested 100000", video(write("{" * 100_000))),
        Case("--anchors FIFO", video(lambda f: fifo(f, "in/anchors.json"))),
        Case("--anchors -> /dev/zero", video(lambda f: link(f, "/dev/zero", "in/anchors.json"))),
        Case("--anchors is a folder", video(lambda f: (os.mkdir(os.path.join(f, "in", "a.json")),
                                                       os.path.join(f, "in", "a.json"))[1])),
    ]


def _hand_manifest(f: str, lst: str) -> None:
    from puppet.batch.jobs import read_job_list
    from puppet.batch.runner import client_digest

    out = os.path.join(f, "out")
    entries, cache = {}, {}
    for j in read_job_list(lst, out, {}):
        os.makedirs(os.path.dirname(j["output"]), exist_ok=True)
        with open(j["output"], "wb") as fh:
            fh.write(b"earlier output")
        entries[j["rel"]] = {"inputs": client_digest(j, cache), "finished": "0"}
    with open(os.path.join(out, "manifest.json"), "w") as fh:
        json.dump({"puppet_batch_manifest": 1, "outputs": entries}, fh)


def cluster_cases() -> list[Case]:
    def resume(tamper, expect=(3,)):
        def setup(f):
            lst = jobs(f, [{"scene": "bar.json", "output": "bar/rest.png"}])
            _hand_manifest(f, lst)
            tamper(f)
            return batch_args(f, lst, "--resume", "--workers", "1")
        return setup

    def image_to(target):
        def tamper(f):
            os.remove(os.path.join(f, "in", "bar.png"))
            if target == "fifo":
                fifo(f, "in/bar.png")
            elif target == "dir":
                os.mkdir(os.path.join(f, "in", "bar.png"))
            else:
                link(f, target, "in/bar.png")
        return tamper

    def output_to_folder(f):
        os.remove(os.path.join(f, "out", "bar", "rest.png"))
        os.makedirs(os.path.join(f, "out", "bar", "rest.png", "mine"))

    def output_to_link(f):
        os.remove(os.path.join(f, "out", "bar", "rest.png"))
        link(f, "../../in/bar.png", "out/bar/rest.png")

    def deep_manifest(f):
        with open(os.path.join(f, "out", "manifest.json"), "w") as fh:
            fh.write('{"puppet_batch_manifest": 1, "outputs": ' + "[" * 100_000 + "}")

    def huge_manifest(f):
        with open(os.path.join(f, "out", "manifest.json"), "wb") as fh:
            fh.truncate(70 * 2 ** 20)

    def many(f):
        return jobs(f, [{"scene": "bar.json", "time": round(0.001 * k, 3), "size": [400, 300],
                         "output": f"t/{k:03d}.png"} for k in range(800)])

    def hard_link(f):
        lst = one_job(f, output="h.png")
        os.link(os.path.join(f, "in", "bar.png"), os.path.join(f, "out", "h.png"))
        return batch_args(f, lst)

    rep = "out/report.json"
    man = "out/manifest.json"
    out = "out/bar/rest.png"
    cases = [
        Case("--workers 64 (capped, one line)", lambda f: batch_args(f, one_job(f), "--workers", "64"),
             expect=(0,), cluster=True),
        Case("resume: image -> /dev/zero", resume(image_to("/dev/zero")), (3,), True, (rep, man)),
        Case("resume: image -> /dev/urandom", resume(image_to("/dev/urandom")), (3,), True, (rep, man)),
        Case("resume: image -> /proc/self/mem", resume(image_to("/proc/self/mem")), (3,), True, (rep, man)),
        Case("resume: image is a FIFO", resume(image_to("fifo")), (3,), True, (rep, man)),
        Case("resume: image is a folder", resume(image_to("dir")), (3,), True, (rep, man)),
        Case("resume: output became a folder", resume(output_to_folder), (3,), True, (rep, man)),
        Case("resume: output became a link to an input", resume(output_to_link), (2,), True),
        Case("resume: manifest nested 100000", resume(deep_manifest), (0,), True, (rep, man, out)),
        Case("resume: manifest 70 MB sparse", resume(huge_manifest), (0,), True, (rep, man, out)),
        Case("resume: scene -> /dev/zero", resume(lambda f: (os.remove(os.path.join(f, "in", "bar.json")),
                                                             link(f, "/dev/zero", "in/bar.json"))),
             (3,), True, (rep, man)),
    ]
    cases.append(Case("output is a hard link of an input", hard_link, (0, 3), True, ("out/h.png",)))
    for sig, after in ((signal.SIGINT, 0.5), (signal.SIGINT, 1.0), (signal.SIGINT, 1.5), (signal.SIGINT, 2.0),
                       (signal.SIGINT, 3.0), (signal.SIGINT, 5.0), (signal.SIGHUP, 1.0), (signal.SIGHUP, 2.0),
                       (signal.SIGHUP, 4.0), (signal.SIGTERM, 0.7), (signal.SIGTERM, 1.2), (signal.SIGTERM, 1.5),
                       (signal.SIGTERM, 2.5), (signal.SIGTERM, 4.0)):
        cases.append(Case(f"{signal.Signals(sig).name} to the group after {after:g} s",
                          lambda f: batch_args(f, many(f), "--workers", "2"), (130, -sig, 0), True,
                          signal_after=(sig, after)))
    return cases


# -- running --------------------------------------------------------------------------------
def _limits():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))


def prepare(base: str, case: Case) -> tuple[str, list[str]]:
    f = tempfile.mkdtemp(prefix="case-", dir=base)
    for d in ("in", "out", "outside", "tmp"):
        os.mkdir(os.path.join(f, d))
    write_bar(os.path.join(f, "in"))
    with open(os.path.join(f, "outside", "keep.txt"), "w") as fh:
        fh.write("nobody writes here\n")
    return f, case.setup(f)


def judge(case: Case, before: dict, after: dict, res: Result) -> None:
    """Flag every change that is not the run's own business."""
    own = {f"{case.out}/report.json", f"{case.out}/manifest.json"}
    for rel in sorted(set(before) | set(after)):
        if before.get(rel) == after.get(rel):
            continue
        inside = rel.startswith(case.out + os.sep)
        if rel in before:
            if rel in case.may_change:
                continue
            if rel in own and before[rel][0] == "file" and after.get(rel, ("",))[0] == "file" and res.rc != 2:
                continue  # the run rewrote its own report / manifest
            res.flags.append(f"input modified: {rel}")
        elif not inside:
            res.flags.append(f"write outside -o: {rel}")
        elif rel.endswith(".tmp") or ".tmp" + os.sep in rel:
            res.flags.append(f"left behind: {rel}")
        elif res.rc == 2:
            res.flags.append(f"write by a refused run: {rel}")


def run_case(base: str, case: Case, python: str) -> Result:
    res = Result(case)
    try:
        f, argv = prepare(base, case)
    except Exception as e:  # noqa: BLE001 - a broken case is reported, the campaign goes on
        res.flags.append(f"setup failed: {e!r}")
        return res
    before = snapshot(f)
    env = dict(os.environ, TMPDIR=os.path.join(f, "tmp"))
    t0 = time.monotonic()
    ran = run_child([python, "-m", "puppet", *argv], timeout=CLUSTER_TIMEOUT if case.cluster else FAST_TIMEOUT,
                    signal_after=case.signal_after, cwd=os.path.join(f, "in"), start_new_session=True, env=env,
                    preexec_fn=_limits)
    res.rc, out, err = ran.rc, ran.out, ran.err
    if ran.hang:
        res.flags.append("hang")
    res.seconds = time.monotonic() - t0
    time.sleep(0.2)  # a process of the group may still be ending
    with_pg_gone(ran.pid)
    res.err = err
    if "Traceback" in err or "Traceback" in out or res.rc == 1:
        res.flags.append("traceback")
    if res.rc is not None and res.rc not in case.expect:
        res.flags.append(f"exit {res.rc} (expected {'/'.join(map(str, case.expect))})")
    if res.rc == 2 and not (err.startswith("puppet: error: ") and err.count("\n") == 1):
        res.flags.append("not one line")
    stray = [line for line in err.splitlines() if line.strip() and not line.startswith("puppet")]
    if stray and "traceback" not in res.flags:
        res.flags.append(f"stray stderr: {stray[0][:80]}")
    judge(case, before, snapshot(f), res)
    shutil.rmtree(f, ignore_errors=True)
    return res


def with_pg_gone(pgid: int) -> None:
    """Kill what is left of the case's process group (a worker that outlived its client)."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        return
    except PermissionError:
        return


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="leave out the cases that start a Dask cluster")
    ap.add_argument("--only", help="run the cases whose name holds this")
    ap.add_argument("-v", action="store_true", help="print every case's stderr")
    ap.add_argument("--against", metavar="DIR", help="run the puppet found in DIR (e.g. an older checkout) instead")
    a = ap.parse_args()
    cases = own_file_cases() + job_list_cases() + output_cases() + scheduler_cases() + flag_cases() + anchors_cases()
    if not a.fast:
        cases += cluster_cases()
    else:
        cases = [c for c in cases if not c.cluster]
    if a.only:
        cases = [c for c in cases if a.only in c.name]
    python = os.path.join(ROOT, ".venv", "bin", "python")
    if a.against:
        os.environ["PYTHONPATH"] = os.path.abspath(a.against)
    base = tempfile.mkdtemp(prefix="campaign-batch-")
    results = []
    t0 = time.monotonic()
    try:
        for case in cases:
            r = run_case(base, case, python)
            results.append(r)
            first = (r.err.strip().splitlines() or [""])[-1][:150]
            print(f"{'FAIL' if r.flags else 'ok  '} {r.seconds:6.1f}s rc={r.rc!s:>4} {case.name}: "
                  f"{'; '.join(r.flags) if r.flags else first}", flush=True)
            if a.v or r.flags:
                for line in r.err.strip().splitlines()[:12]:
                    print(f"        | {line[:200]}")
    finally:
        for s in SERVERS:
            s.close()
        shutil.rmtree(base, ignore_errors=True)

    def count(word):
        return sum(any(fl.startswith(word) for fl in r.flags) for r in results)

    print(f"\ncases {len(results)} in {time.monotonic() - t0:.0f} s: tracebacks {count('traceback')}, "
          f"hangs {count('hang')}, inputs modified {count('input modified')}, "
          f"writes outside -o {count('write outside')}, not one line {count('not one line')}, "
          f"left behind {count('left behind')}, stray stderr {count('stray')}, writes by refused runs "
          f"{count('write by a refused') + count('own file rewritten')}, unexpected exit {count('exit ')}, "
          f"setup failures {count('setup failed')}")
    return 1 if any(r.flags for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
