"""What a batch checks on the client before anything runs, so that it never destroys a file:

- no output (a file, or anything inside an animation folder) is a file that **any** job of
  the run reads: a scene, a layer image, a mask file, a source or background picture, a
  template picture, the job list itself (:func:`check_outputs`);
- the batch's own ``report.json`` and ``manifest.json`` are regular files it may replace,
  never a symbolic link it would write through, a FIFO, a device or a folder, and never an
  input (:func:`check_own_files`);
- ``--resume`` counts an output as present only when it is what the job writes (a regular
  file, or a frame folder) (:func:`output_present`).

Every refusal is a :class:`~puppet.errors.SceneError` (one line, exit status 2) raised before
a cluster starts or a file is written.
"""
from __future__ import annotations

import os
import stat

from puppet.batch.jobs import RESERVED, extra_outputs
from puppet.errors import SceneError

Inputs = list[tuple[str, str]]


def scene_inputs(jobs: list[dict]) -> dict[str, Inputs | None]:
    """Scene path -> the files it reads (:func:`puppet.scene.format.inputs.input_files`), or None
    when the scene cannot be read (its job will fail; only the scene file is then known)."""
    from puppet.scene.document.core import Document  # lazy: numpy (see puppet/batch/__init__.py)
    from puppet.scene.format.inputs import input_files  # lazy: numpy (see puppet/batch/__init__.py)

    found: dict[str, Inputs | None] = {}
    for j in jobs:
        path = j["scene"]
        if path not in found:
            try:
                found[path] = input_files(Document.load(path).data)
            except (SceneError, OSError, ValueError):
                found[path] = None
    return found


def all_inputs(jobs: list[dict], scenes: dict[str, Inputs | None], extra: Inputs = ()) -> dict[str, str]:
    """Real path -> a description ("layers[0].image of /abs/trex.json") of every file the run reads."""
    out: dict[str, str] = {}

    def add(path: str, what: str) -> None:
        real = os.path.realpath(path)
        out.setdefault(real, what)

    for path, what in extra:
        add(path, what)
    for scene, inputs in scenes.items():
        add(scene, f"the scene file {scene}")
        for path, what in inputs or ():
            if what != "the scene file":
                add(path, f"{what} of {scene}")
    for j in jobs:
        if j.get("image"):
            add(j["image"], f"the picture of job {j['id']}")
    return out


def check_outputs(jobs: list[dict], inputs: dict[str, str], file: str | None) -> None:
    """Refuse a job whose output is, or (a folder) holds, a file some job of the run reads."""
    under = sorted(inputs)
    for j in jobs:
        out = j["output"]
        if out.endswith(os.sep):
            prefix = out
            hit = next((p for p in under if p.startswith(prefix) or p == out.rstrip(os.sep)), None)
        else:
            hit = next((p for p in [out] + extra_outputs(j) if p in inputs), None)
        if hit is not None:
            name = j["rel"] if hit == out else os.path.relpath(hit, os.path.dirname(out))  # a garment (template jobs)
            raise SceneError(f"job {j['id']}: output {name!r} would replace {hit!r}, which the batch reads "
                             f"({inputs[hit]})", file=file)


def check_own_files(out_dir: str, inputs: dict[str, str]) -> None:
    """``report.json`` and ``manifest.json`` in OUT_DIR: absent, or regular files that are not inputs."""
    for name in RESERVED:
        path = os.path.join(out_dir, name)
        try:
            st = os.lstat(path)
        except FileNotFoundError:
            continue
        except OSError as e:
            raise SceneError(f"cannot be checked ({e.strerror})", file=path) from None
        if stat.S_ISLNK(st.st_mode):
            raise SceneError(f"is a symbolic link; puppet batch writes its own {name} there and never "
                             "writes through a link: remove it or give another OUT_DIR", file=path)
        if not stat.S_ISREG(st.st_mode):
            raise SceneError(f"is not a regular file; puppet batch writes its own {name} there: "
                             "remove it or give another OUT_DIR", file=path)
        if os.path.realpath(path) in inputs:
            raise SceneError(f"is a file the batch reads ({inputs[os.path.realpath(path)]}); puppet batch "
                             f"writes its own {name} there: give another OUT_DIR", file=path)


def output_present(job: dict) -> bool:
    """The job's output exists as what the job writes: a regular file (not a link), or a
    folder; and so do the files it writes besides (a ``--dressroom`` garment)."""
    out = job["output"]
    try:
        st = os.lstat(out.rstrip(os.sep))
        extra = [os.lstat(p) for p in extra_outputs(job)]
    except OSError:
        return False
    if not all(stat.S_ISREG(e.st_mode) for e in extra):
        return False
    return stat.S_ISDIR(st.st_mode) if out.endswith(os.sep) else stat.S_ISREG(st.st_mode)


def unchanged_path(output: str) -> str | None:
    """None when ``output`` (a real path, checked by the client) still resolves to itself;
    else why not (a folder on its way became a symbolic link since the client checked)."""
    plain = output.rstrip(os.sep)
    try:
        real = os.path.realpath(plain)
    except (OSError, ValueError) as e:
        return str(e)
    if real != plain:
        return f"its path now goes through a symbolic link (to '{real}'); not written"
    return None
