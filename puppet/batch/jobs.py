"""The jobs of a batch: read from a job list (JSON or JSONL), made from a folder of scenes,
or from a garment template and a folder of images; outputs checked to stay inside OUT_DIR.

A job is a plain dict (cheap to send to a Dask worker), with absolute paths::

    {"id": 0, "kind": "pose" | "time" | "animate" | "template",
     "scene": "/abs/scene.json", "pose": "reach", "time": 0.5, "animate": {"fps": .., "from": .., "to": ..},
     "image": "/abs/photo.png", "tolerance": 0.1,          # template jobs
     "size": [W, H] | None, "wireframe": False, "budget": 300.0,
     "output": "/abs/OUT_DIR/rel/path.png", "rel": "rel/path.png"}

Errors in the command input (the list, a flag) raise :class:`~puppet.errors.SceneError`
(one line, exit status 2); a scene that cannot be read is not a command error but a failed
job (see :func:`folder_jobs`).
"""
from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable

from puppet.anim import formats
from puppet.anim.options import MAX_FPS, MIN_FPS  # the limits of ``puppet animate --fps``
from puppet.errors import SceneError

#: Extensions of the images taken by template mode.
IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff")
#: Files of OUT_DIR that belong to the batch itself.
RESERVED = ("report.json", "manifest.json")
#: Extensions of a single-frame output.
FRAME_EXTS = (".png",)
#: Endings of an animation's output file: the formats table's single-file formats, or a folder (ending in /).
ANIM_EXTS = tuple(e for e in formats.suffixes(single=True) if e != "/")
JOB_KEYS = {"scene", "pose", "time", "animate", "size", "output", "wireframe", "budget"}
ANIM_KEYS = {"fps", "from", "to"}
#: Largest job list read (bytes).
MAX_LIST_BYTES = 64 * 1024 * 1024


def parse_size(v, file: str | None, path: str, check=None) -> list[int] | None:
    """``[W, H]`` or ``"WxH"`` -> [W, H] (None stays None); raises SceneError.

    ``check`` is the CLI's ``--size`` parser (the same limits as ``puppet render``): it takes
    ``"WxH"`` and raises ``argparse.ArgumentTypeError``.
    """
    if v is None:
        return None
    if isinstance(v, str):
        m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", v)
        v = [int(m.group(1)), int(m.group(2))] if m else None
    if not (isinstance(v, list) and len(v) == 2 and all(isinstance(x, int) and not isinstance(x, bool) for x in v)):
        raise SceneError("size must be [W, H] or \"WxH\" with whole numbers", file=file, path=path)
    if check is not None:
        try:
            check(f"{v[0]}x{v[1]}")
        except Exception as e:  # argparse.ArgumentTypeError
            raise SceneError(str(e).replace("--size ", "size "), file=file, path=path) from None
    elif min(v) < 1:
        raise SceneError("size: width and height must be >= 1", file=file, path=path)
    return v


def _number(v, file, path, what, *, low=0.0) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < low:
        raise SceneError(f"{what} must be a finite number >= {low:g}", file=file, path=path)
    return float(v)


def resolve_output(out_dir: str, rel: str, file: str | None, path: str) -> tuple[str, str]:
    """The absolute output and its normalised path relative to ``out_dir`` (real path).

    Refuses absolute paths, paths leaving OUT_DIR (``..``, or a symlink inside it that
    points out) and the batch's own files (``report.json``, ``manifest.json``).
    """
    if not isinstance(rel, str) or not rel.strip():
        raise SceneError("output must be a non-empty path relative to OUT_DIR", file=file, path=path)
    if _CONTROL.search(rel):
        raise SceneError(f"output {rel!r}: a control character (NUL, newline, ...) in a file name", file=file,
                         path=path)
    folder = rel.endswith(("/", os.sep))
    if os.path.isabs(rel):
        raise SceneError(f"output {rel!r} must be relative to OUT_DIR", file=file, path=path)
    norm = os.path.normpath(rel)
    full = os.path.realpath(os.path.join(out_dir, norm))
    if not full.startswith(out_dir.rstrip(os.sep) + os.sep):
        raise SceneError(f"output {rel!r} leaves OUT_DIR", file=file, path=path)
    link = _link_on_the_way(out_dir, norm)
    if link is not None:
        raise SceneError(f"output {rel!r} goes through the symbolic link {link!r}: outputs never follow "
                         "links they did not make", file=file, path=path)
    norm = os.path.relpath(full, out_dir).replace(os.sep, "/")
    if norm in RESERVED:
        raise SceneError(f"output {rel!r} is the batch's own {norm}", file=file, path=path)
    return full + (os.sep if folder else ""), norm + ("/" if folder else "")


_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def _link_on_the_way(out_dir: str, norm: str) -> str | None:
    """The first part of OUT_DIR/``norm`` that is a symbolic link (relative to OUT_DIR), or None."""
    cur = out_dir
    for part in norm.split(os.sep):
        if part in ("", "."):
            continue
        cur = os.path.join(cur, part)
        if os.path.islink(cur):
            return os.path.relpath(cur, out_dir)
        if not os.path.isdir(cur):
            return None
    return None


def _fmt_time(t: float) -> str:
    return f"t{t:g}".replace(".", "_")


def default_output(job: dict) -> str:
    """Where a job without ``output`` writes: ``STEM/POSE.png``, ``STEM/t0_5.png``, ``STEM/animation.gif``."""
    stem = os.path.splitext(os.path.basename(job["scene"]))[0]
    if job["kind"] == "animate":
        return f"{stem}/animation.gif"
    if job["kind"] == "time":
        return f"{stem}/{_fmt_time(job['time'])}.png"
    return f"{stem}/{job['pose']}.png"


def _kind_ext(kind: str, rel: str, file, path) -> None:
    if kind == "animate":
        if not (rel.endswith("/") or rel.lower().endswith(ANIM_EXTS)):
            raise SceneError(f"output {rel!r}: an animation goes to a folder (ending in /) or a file "
                             f"ending in {', '.join(ANIM_EXTS)}",
                             file=file, path=path)
    elif rel.endswith("/") or os.path.splitext(rel)[1].lower() not in FRAME_EXTS:
        raise SceneError(f"output {rel!r}: a frame goes to a .png file", file=file, path=path)


def job_from_entry(e, base: str, out_dir: str, defaults: dict, file: str, path: str) -> dict:
    """One job from a job-list entry (paths relative to ``base``, the list's folder)."""
    if not isinstance(e, dict):
        raise SceneError("a job is an object {\"scene\": ..., \"pose\" | \"time\" | \"animate\": ...}",
                         file=file, path=path)
    unknown = sorted(set(e) - JOB_KEYS)
    if unknown:
        raise SceneError(f"unknown key {unknown[0]!r} (keys: {', '.join(sorted(JOB_KEYS))})", file=file, path=path)
    if not isinstance(e.get("scene"), str) or not e["scene"]:
        raise SceneError("'scene' (a scene file) is required", file=file, path=f"{path}.scene")
    if "\x00" in e["scene"]:
        raise SceneError("scene: a NUL byte in a file name", file=file, path=f"{path}.scene")
    job = {"scene": os.path.normpath(os.path.join(base, e["scene"])), "size": defaults.get("size"),
           "wireframe": False, "budget": defaults.get("budget")}
    given = [k for k in ("pose", "time", "animate") if k in e]
    if len(given) > 1:
        raise SceneError(f"give one of 'pose', 'time', 'animate', not {' and '.join(given)}", file=file, path=path)
    kind = given[0] if given else "pose"
    job["kind"] = kind
    if kind == "pose":
        pose = e.get("pose", "rest")
        if not isinstance(pose, str) or not pose or _CONTROL.search(pose):
            raise SceneError("pose must be a pose name (no control characters)", file=file, path=f"{path}.pose")
        job["pose"] = pose
    elif kind == "time":
        job["time"] = _number(e["time"], file, f"{path}.time", "time")
    else:
        a = e["animate"]
        if a is True:
            a = {}
        if not isinstance(a, dict) or set(a) - ANIM_KEYS:
            raise SceneError("animate is true or an object with fps, from, to", file=file, path=f"{path}.animate")
        job["animate"] = {k: _number(a[k], file, f"{path}.animate.{k}", k) for k in ANIM_KEYS if k in a}
        _check_fps(job["animate"], file, f"{path}.animate.fps")
    if "size" in e:
        job["size"] = parse_size(e["size"], file, f"{path}.size", defaults.get("check_size"))
    if "wireframe" in e:
        if not isinstance(e["wireframe"], bool):
            raise SceneError("wireframe must be true or false", file=file, path=f"{path}.wireframe")
        job["wireframe"] = e["wireframe"]
    if "budget" in e:
        job["budget"] = _number(e["budget"], file, f"{path}.budget", "budget", low=0.001)
    rel = e.get("output", default_output(job))
    job["output"], job["rel"] = resolve_output(out_dir, rel, file, f"{path}.output")
    _kind_ext(kind, job["rel"], file, f"{path}.output")
    return job


def _check_fps(anim: dict, file, path) -> None:
    if "fps" in anim and not MIN_FPS <= anim["fps"] <= MAX_FPS:
        raise SceneError(f"fps {anim['fps']:g} is outside {MIN_FPS:g}..{MAX_FPS:g} (as animate --fps)",
                         file=file, path=path)


def read_job_list(file: str, out_dir: str, defaults: dict) -> list[dict]:
    """Jobs of a JSON (a list, or ``{"jobs": [...]}``) or JSONL (one object a line) file.

    The file is read as a scene file is (:mod:`puppet.scene.format.reader`): a regular file of at
    most :data:`MAX_LIST_BYTES`, strict JSON (no NaN, integers up to 2^53, nesting up to
    32 levels, no repeated key); anything else is one SceneError naming the file."""
    from puppet.scene.format.reader import parse_text, read_file  # lazy: numpy (see puppet/batch/__init__.py)

    text = read_file(file, what="job list", max_bytes=MAX_LIST_BYTES)
    base = os.path.dirname(os.path.abspath(file))
    entries: list[tuple[object, str]] = []
    if file.lower().endswith(".jsonl"):
        for n, line in enumerate(text.splitlines(), 1):
            if line.strip():
                try:
                    entries.append((parse_text(line, file), f"line {n}"))
                except SceneError as e:
                    sub = e.path or ""
                    where = f"line {n}" + ("." if sub and not sub.startswith("[") else "") + sub
                    raise SceneError(e.message.replace("at line 1 column", "at column"), file=file,
                                     path=where) from None
    else:
        raw = parse_text(text, file)
        if isinstance(raw, dict) and "layers" in raw and "jobs" not in raw:
            raise SceneError("this is a scene, not a job list: give a folder of scenes or a job list "
                             "(puppet render / animate for one scene)", file=file)
        prefix = "jobs" if isinstance(raw, dict) else ""
        if isinstance(raw, dict):
            raw = raw.get("jobs")
        if not isinstance(raw, list):
            raise SceneError("a job list is a JSON list of jobs, {\"jobs\": [...]}, or JSONL", file=file)
        entries = [(e, f"{prefix}[{i}]") for i, e in enumerate(raw)]
    if not entries:
        raise SceneError("the job list is empty", file=file)
    return number([job_from_entry(e, base, out_dir, defaults, file, p) for e, p in entries], file)


def number(jobs: Iterable[dict], file: str | None) -> list[dict]:
    """Give jobs their ids; two jobs writing one output are refused (or one inside the other's folder)."""
    jobs = list(jobs)
    seen: dict[str, int] = {}
    for i, job in enumerate(jobs):
        job["id"] = i
        key = job["rel"].rstrip("/")
        if key in seen:
            raise SceneError(f"jobs {seen[key]} and {i} both write {key!r}", file=file)
        seen[key] = i
    folders = sorted(j["rel"] for j in jobs if j["rel"].endswith("/"))
    for f in folders:
        inside = next((j for j in jobs if j["rel"] != f and j["rel"].startswith(f)), None)
        if inside is not None:
            raise SceneError(f"job {inside['id']} writes {inside['rel']!r} inside an animation folder {f!r}",
                             file=file)
    return jobs


def folder_jobs(folder: str, out_dir: str, defaults: dict) -> list[dict]:
    """Every pose (rest included) and the animation (``animation.gif``) of every scene file
    (``*.json``, not recursive) in ``folder``; outputs ``STEM/POSE.png``.

    A file that is not a valid scene still gives one job (its ``rest`` pose), which then
    fails with the scene's error: it is reported, never skipped silently.
    """
    from puppet.scene.document.core import Document  # lazy: numpy (see puppet/batch/__init__.py)

    names = sorted(n for n in os.listdir(folder) if n.lower().endswith(".json")
                   and os.path.isfile(os.path.join(folder, n)))
    if not names:
        raise SceneError("no scene files (*.json) in the folder", file=folder)
    jobs = []
    for n in names:
        scene = os.path.join(folder, n)
        base = {"scene": scene, "size": defaults.get("size"), "wireframe": False, "budget": defaults.get("budget")}
        try:
            doc = Document.load(scene)
            poses, anim = doc.pose_names(), doc.data.animation is not None
        except SceneError:
            poses, anim = ["rest"], False
        for p in poses:
            jobs.append(dict(base, kind="pose", pose=p))
        if anim:
            jobs.append(dict(base, kind="animate", animate={}))
    for j in jobs:
        j["output"], j["rel"] = resolve_output(out_dir, default_output(j), folder, "output")
    return number(jobs, folder)


def template_jobs(template: str, images: str, pose: str, out_dir: str, defaults: dict, *,
                  tolerance: float | None, room: dict | None = None) -> list[dict]:
    """One job per image (sorted, not recursive) in ``images``: transfer ``template``'s pins
    to it and render ``pose``; outputs ``STEM.png`` (``STEM_EXT.png`` when two images share a stem).

    ``room`` (``--dressroom``: the template's ``canvas`` and garment ``category``): each
    job also writes its garment, ``garments/STEM.json`` and ``garments/STEM.png``, and
    its room pictures, ``garments/STEM.room.zip`` (:mod:`puppet.batch.dressroom`)."""
    if not os.path.isdir(images):
        raise SceneError("--images: not a folder", file=images)
    names = sorted(n for n in os.listdir(images) if os.path.splitext(n)[1].lower() in IMAGE_EXTS
                   and os.path.isfile(os.path.join(images, n)))
    if not names:
        raise SceneError(f"--images: no images ({', '.join(IMAGE_EXTS)}) in the folder", file=images)
    stems = [os.path.splitext(n)[0] for n in names]
    jobs = []
    for n, stem in zip(names, stems):
        rel = f"{stem}.png" if stems.count(stem) == 1 else f"{stem}_{os.path.splitext(n)[1][1:].lower()}.png"
        job = {"kind": "template", "scene": template, "image": os.path.join(images, n), "pose": pose,
               "tolerance": tolerance, "size": defaults.get("size"), "wireframe": False,
               "budget": defaults.get("budget")}
        job["output"], job["rel"] = resolve_output(out_dir, rel, images, "output")
        if room is not None:
            job["room"] = dict(room, **_garment_paths(out_dir, job["rel"], images))
        jobs.append(job)
    return number(jobs, images)


#: Folder of OUT_DIR holding the garments of ``--dressroom``.
GARMENTS = "garments"


def _garment_paths(out_dir: str, rel: str, file: str) -> dict:
    stem = os.path.splitext(rel)[0]
    scene, rel_scene = resolve_output(out_dir, f"{GARMENTS}/{stem}.json", file, "output")
    picture, _ = resolve_output(out_dir, f"{GARMENTS}/{stem}.png", file, "output")
    drawn, _ = resolve_output(out_dir, f"{GARMENTS}/{stem}{DRAWN}", file, "output")
    return {"scene": scene, "picture": picture, "drawn": drawn, "rel": rel_scene}


#: Ending of the file holding a ``--dressroom`` garment's room pictures, drawn by its job.
DRAWN = ".room.zip"


def extra_outputs(job: dict) -> list[str]:
    """The files a job writes besides its output (a ``--dressroom`` garment), absolute."""
    room = job.get("room")
    return [room["picture"], room["scene"], room["drawn"]] if room else []


def describe(job: dict) -> dict:
    """What a report says of a job (no absolute output path, which OUT_DIR gives)."""
    d = {"id": job["id"], "scene": job["scene"], "output": job["rel"]}
    if job["kind"] == "template":
        d.update(image=job["image"], pose=job["pose"])
    elif job["kind"] == "animate":
        d["animate"] = job["animate"]
    else:
        d[job["kind"]] = job[job["kind"]]
    if job.get("size"):
        d["size"] = job["size"]
    if job.get("room"):
        d["garment"] = job["room"]["rel"]
    return d


def spec(job: dict) -> dict:
    """What, besides the input files' content, decides a job's output (hashed for --resume)."""
    keys = ("kind", "pose", "time", "animate", "size", "wireframe", "tolerance", "rel")
    out = {k: job.get(k) for k in keys}
    if job.get("room"):  # only then: the hashes of other jobs stay as they were
        out["room"] = [job["room"]["canvas"], job["room"]["category"]]
    return out
