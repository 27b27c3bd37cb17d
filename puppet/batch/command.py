"""``puppet batch``: its arguments and how it runs (imported by puppet.cli; keep it cheap to import:
Dask is imported only when a batch runs).

Exit status: 0 every job done (or skipped by --resume as up to date); 2 bad command input
(one line); 3 the batch ran to its end but some jobs failed (``report.json`` says which and
why); 130 interrupted (Ctrl+C: OUT_DIR consistent, ``--resume`` finishes the rest).
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys

from puppet.errors import SceneError
from puppet.output import check_folder


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: give a number of seconds > 0")
    return v


def _count(low: int):
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if not low <= v <= 1024:
            raise argparse.ArgumentTypeError(f"{text!r}: give {low}..1024")
        return v
    return parse


def _tolerance(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (v >= 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: the tolerance must be a finite number >= 0")
    return v


_check_size = None  # the CLI's --size parser, for sizes in job lists (same limits)


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    global _check_size
    _check_size = size
    b = sub.add_parser("batch", help="render many scenes / poses / garment images on Dask",
                       description="JOBS is a folder of scene files (every pose and the animation of each) "
                                   "or a JSON/JSONL job list (docs/batch.md). Template mode: --template "
                                   "garment.json --images DIR/ --pose NAME (JOBS omitted). Exit status: 0 all "
                                   "done, 2 bad input, 3 some jobs failed (OUT_DIR/report.json), 130 interrupted.")
    b.add_argument("jobs", nargs="?", metavar="JOBS", help="a folder of scenes or a JSON/JSONL job list")
    b.add_argument("-o", "--output", required=True, metavar="OUT_DIR/")
    b.add_argument("--workers", type=_count(1), metavar="N", help="worker processes (default: the cores)")
    b.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="an existing Dask scheduler")
    b.add_argument("--retries", type=_count(0), default=2, metavar="K",
                   help="runs again a job whose worker died, up to K times (default 2)")
    b.add_argument("--resume", action="store_true", help="skip jobs whose output is up to date")
    b.add_argument("--size", type=size, metavar="WxH", help="output size of jobs that give none (default: the canvas)")
    b.add_argument("--budget", type=_seconds, default=300.0, metavar="SECONDS",
                   help="most time a job may spend loading and solving before it fails (default 300)")
    t = b.add_argument_group("template mode")
    t.add_argument("--template", metavar="GARMENT.json", help="a garment scene whose pins go to each image")
    t.add_argument("--images", metavar="DIR/", help="the garment images")
    t.add_argument("--pose", metavar="NAME", help="the template's pose to render each image in")
    t.add_argument("--tolerance", type=_tolerance, metavar="T",
                   help="how far an outline may differ from the template's (default: the algorithm's)")
    t.add_argument("--dressroom", metavar="MANNEQUIN",
                   help="also write OUT_DIR/room/: the dressing room of every matched garment on MANNEQUIN (a "
                        "picture or a scene on the template's canvas; see docs/dressroom.md)")
    return b


def _jobs(args: argparse.Namespace, out_dir: str) -> list[dict]:
    from puppet.batch import jobs as J  # lazy: the batch's modules (the CLI's parser imports this one)

    defaults = {"size": list(args.size) if args.size else None, "budget": args.budget, "check_size": _check_size}
    template_flags = [f for f in ("template", "images", "pose", "tolerance", "dressroom")
                      if getattr(args, f) is not None]
    if args.template is not None:
        if args.jobs is not None:
            raise SceneError("give JOBS or --template, not both")
        missing = [f"--{f}" for f in ("images", "pose") if getattr(args, f) is None]
        if missing:
            raise SceneError(f"--template needs {' and '.join(missing)}")
        template = os.path.abspath(args.template)
        doc = _check_pose(template, args.pose)
        room = _room(args, doc, out_dir) if args.dressroom is not None else None
        return J.template_jobs(template, os.path.abspath(args.images), args.pose, out_dir, defaults,
                               tolerance=args.tolerance, room=room)
    if template_flags:
        raise SceneError(f"--{template_flags[0]} is for template mode (with --template)")
    if args.jobs is None:
        raise SceneError("give JOBS (a folder of scenes or a job list) or --template")
    path = os.path.abspath(args.jobs)
    if os.path.isdir(path):
        if os.path.realpath(path) == out_dir:
            raise SceneError("OUT_DIR must not be the JOBS folder", file=args.output)
        return J.folder_jobs(path, out_dir, defaults)
    if not os.path.exists(path):
        raise SceneError("no such file or folder", file=args.jobs)
    if not path.lower().endswith((".json", ".jsonl")):
        raise SceneError("JOBS is a folder of scenes or a .json / .jsonl job list", file=args.jobs)
    return J.read_job_list(path, out_dir, defaults)


def _check_pose(template: str, pose: str) -> None:
    from puppet.scene.document.core import Document  # lazy: numpy and scipy

    doc = Document.load(template)
    if pose not in doc.pose_names():
        raise SceneError(f"--pose {pose!r}: no such pose (poses: {', '.join(doc.pose_names())})", file=template)
    return doc


def _room(args: argparse.Namespace, doc, out_dir: str) -> dict:
    """``--dressroom``: the mannequin read (a scene drawn at rest) and checked against the
    template's canvas, the room's folder checked, before any job runs; the jobs' ``room``.
    Keeps the mannequin's picture in ``args.mannequin_rgba`` for the end of the batch."""
    from puppet.batch import dressroom  # lazy: the room's modules (numpy, the scene stack)
    from puppet.batch import jobs as J  # lazy: the batch's modules (the CLI's parser imports this one)
    from puppet.room.model import load_mannequin  # lazy: as above
    from puppet.scene.format.garment import DEFAULT_CATEGORY  # lazy: as above

    if not os.path.exists(args.dressroom):
        raise SceneError("--dressroom: no such file", file=args.dressroom)
    rgba = load_mannequin(args.dressroom)
    h, w = rgba.shape[:2]
    canvas = tuple(doc.canvas)
    if canvas != (w, h):
        raise SceneError(f"--dressroom: the mannequin is {w}x{h}, the template's canvas {canvas[0]}x{canvas[1]} "
                         f"({doc.file}): a room's garments are drawn on the mannequin's canvas", file=args.dressroom)
    if os.path.isdir(out_dir):
        J.resolve_output(out_dir, f"{dressroom.ROOM}/", args.output, "--dressroom")  # no link on the way
        dressroom.check_room_folder(os.path.join(out_dir, dressroom.ROOM), [(args.dressroom, "the mannequin")])
    args.mannequin_rgba = rgba
    garment = doc.data.garment or {}
    return {"canvas": [w, h], "category": garment.get("category", DEFAULT_CATEGORY)}


def _out_dir(path: str) -> str:
    real = os.path.realpath(path)
    if os.path.exists(real) and not os.path.isdir(real):
        raise SceneError("exists and is not a folder", file=path)
    if not os.path.exists(real):
        check_folder(path, contents=False)  # its parent must exist and be writable
        try:
            os.mkdir(real)
        except OSError as e:
            raise SceneError(f"cannot create the folder: {e.strerror or e}", file=path) from None
    elif not os.access(real, os.W_OK):
        raise SceneError("the folder is not writable", file=path)
    return real


def _reads(args: argparse.Namespace) -> dict:
    """What :func:`puppet.batch.runner.run_batch` must protect besides the jobs' own files,
    and the file its command errors name."""
    if args.template is not None:
        reads = [(os.path.abspath(args.template), "--template")]
        if args.dressroom is not None:
            reads.append((os.path.abspath(args.dressroom), "--dressroom"))
        return {"reads": reads, "source": args.images}
    if os.path.isdir(args.jobs):
        return {"reads": [], "source": args.jobs}
    return {"reads": [(os.path.abspath(args.jobs), "the job list")], "source": args.jobs}


def _finale(args: argparse.Namespace, out_dir: str, say):
    """``--dressroom``: what writes the room once every job ran (None without it)."""
    if args.dressroom is None:
        return None

    def room(batch) -> dict:
        from puppet.batch import dressroom  # lazy: the room's modules (numpy, the scene stack)
        from puppet.errors import one_line  # lazy: as above

        scenes = [j["room"]["scene"] for j in batch.jobs
                  if batch.records.get(j["id"], {}).get("status") in ("done", "skipped")
                  and os.path.isfile(j["room"]["scene"])]
        inputs = [(p, "an input of the batch") for p in sorted(batch.keep)]
        try:
            out = dressroom.make_room(out_dir, args.mannequin_rgba, args.dressroom, scenes, inputs=inputs, say=say)
        except SceneError as e:  # the room cannot be written: said and reported, the jobs' outputs stand
            line = one_line(e)
            say(f"puppet batch: dressroom: the room was not written: {line}")
            return {"folder": None, "error": line}
        say(f"puppet batch: dressroom: {len(out['garments'])} garments in {os.path.join(args.output, 'room', '')}"
            + (f" ({len(out['refused'])} left out)" if out["refused"] else ""))
        return out
    return room


def run(args: argparse.Namespace) -> int:
    from puppet.batch.reach import parse_address  # lazy: the batch's modules (the CLI's parser imports this one)
    from puppet.batch.runner import SOME_FAILED, run_batch  # lazy: as above

    if args.scheduler is not None:
        parse_address(args.scheduler)  # its form now; whether it answers once the jobs are known
        if args.workers:
            raise SceneError("--workers is for the embedded cluster; an existing --scheduler has its own workers")
    if args.output and os.path.exists(args.output) and not os.path.isdir(args.output):
        raise SceneError("exists and is not a folder", file=args.output)
    out_dir = os.path.realpath(args.output)
    jobs = _jobs(args, out_dir)  # every command error is found before OUT_DIR is made or touched
    created = not os.path.exists(out_dir)
    out_dir = _out_dir(args.output)

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    try:
        summary = run_batch(jobs, out_dir, workers=args.workers, scheduler=args.scheduler, retries=args.retries,
                            resume=args.resume, progress=sys.stderr.isatty(), say=say,
                            finale=_finale(args, out_dir, say), **_reads(args))
    except SceneError:  # e.g. the scheduler cannot be reached: nothing ran, leave nothing behind
        if created:
            with contextlib.suppress(OSError):
                os.rmdir(out_dir)  # only when still empty
        raise
    c, secs = summary["counts"], summary["seconds"]
    failed = c["failed"] + c["no-match"]
    line = (f"puppet batch: {len(jobs)} jobs: {c['done']} done, {failed} failed"
            + (f" ({c['no-match']} no outline match)" if c["no-match"] else "")
            + f", {c['skipped']} up to date in {secs:.1f} s ({summary['jobs_per_s']:.1f} jobs/s); "
            f"report: {summary['report']}")
    try:
        print(line, flush=True)
    except BrokenPipeError:
        pass
    return SOME_FAILED if failed else 0
