"""What a Dask worker runs: a chunk of jobs, each rendered and written by the worker
itself; only a small record per job goes back to the client.

Each worker process keeps, for as long as it lives:

* one :class:`~puppet.render.compositor.Compositor` (one EGL context), created on the
  first frame the worker draws: never in the client process;
* the last :data:`SCENE_CACHE` loaded scenes, by path, each with the content hash of its
  files: a job for a scene already loaded (and unchanged) reuses its meshes, solver
  factorisations and textures.

A job's failure (bad scene, corrupt image, no outline match, solve over its budget) is
its record's ``error``, one line; the worker goes on with the next job.
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import socket
import threading
import time
from collections import OrderedDict

from puppet.batch.guard import unchanged_path
from puppet.batch.jobs import spec
from puppet.batch.state import inputs_digest
from puppet.errors import SceneError, one_line
from puppet.output import save_png

#: Scenes kept loaded per worker (each holds its images, meshes and factorisations).
SCENE_CACHE = 4

_WHO = f"{socket.gethostname()}:{os.getpid()}"  # the worker process, as reports name it
_compositors: dict[int, object] = {}  # thread id -> compositor (a GL context is current in one thread)
_scenes: OrderedDict[str, tuple[str, list, object]] = OrderedDict()  # path -> (files hash, inputs, scene)


class BudgetExceeded(BaseException):
    """Raised inside a job's thread when its solve runs over the job's budget (a
    BaseException, so that no ``except Exception`` on the way swallows it)."""


def compositor():
    """The worker's compositor (its one GL context), created on first use.

    One per thread, since an EGL context is current in one thread only; a Dask worker with
    one thread runs every task in the same executor thread, so that is one per worker.
    """
    tid = threading.get_ident()
    comp = _compositors.get(tid)
    if comp is None:
        from puppet.render.compositor import Compositor  # lazy: moderngl (the client imports Runner, draws nothing)

        comp = _compositors[tid] = Compositor()
    # Each frame starts like a fresh `puppet render`'s (K-buffer first, A-buffer on overflow),
    # so a job's pixels never depend on what this worker drew before.
    comp.forget_overflow()
    return comp


def _reset_compositor() -> None:
    """Drop this thread's compositor after a GL failure (the next job makes a new one)."""
    comp = _compositors.pop(threading.get_ident(), None)
    if comp is not None:
        with contextlib.suppress(Exception):
            comp.release()


@contextlib.contextmanager
def budget(seconds: float | None, what: str):
    """Raise :class:`BudgetExceeded` in this thread if the block runs over ``seconds``.

    The exception is delivered asynchronously at the next Python step of the block (a
    long call into C finishes first); only CPU work (loading, meshing, solving) runs
    under a budget, never GL drawing or file writing.
    """
    if not seconds:
        yield
        return
    tid = threading.get_ident()
    lock = threading.Lock()
    armed = [True]

    def fire():
        with lock:
            if armed[0]:
                armed[0] = False
                ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(tid), ctypes.py_object(BudgetExceeded))

    timer = threading.Timer(seconds, fire)
    timer.daemon = True
    t0 = time.perf_counter()
    try:
        try:
            timer.start()
            yield
        finally:
            with lock:
                armed[0] = False
            timer.cancel()
    except BudgetExceeded:
        raise BudgetExceeded(f"{what} ran over the job's budget of {seconds:g} s "
                             f"(stopped after {time.perf_counter() - t0:.1f} s)") from None


def _scene(path: str):
    """(files hash, inputs, scene) of a scene file, from the cache when its files are unchanged."""
    from puppet.api import Scene  # lazy: numpy (see puppet/batch/__init__.py)
    from puppet.scene.format.inputs import input_files  # lazy: numpy (see puppet/batch/__init__.py)

    hit = _scenes.get(path)
    if hit is not None:
        with contextlib.suppress(OSError):
            if inputs_digest({}, hit[1]) == hit[0]:
                _scenes.move_to_end(path)
                return hit
        del _scenes[path]
    scene = Scene.load(path)
    inputs = input_files(scene.data)
    entry = (inputs_digest({}, inputs), inputs, scene)
    _scenes[path] = entry
    while len(_scenes) > SCENE_CACHE:
        _scenes.popitem(last=False)
        comp = _compositors.get(threading.get_ident())
        if comp is not None:  # the dropped scene's layer textures go too (a catalogue's names may all differ)
            comp.retain({L.name for _, _, sc in _scenes.values() for L in sc.data.layers})
    return entry


def _template_scene(job: dict):
    """(hashed inputs, every input, scene, transfer) of a template job: the template's pins
    transferred to the image (:class:`puppet.batch.template.Transfer`)."""
    from puppet.api import Scene  # lazy: numpy (see puppet/batch/__init__.py)
    from puppet.batch import template  # lazy: numpy (see puppet/batch/__init__.py)
    from puppet.scene.format.inputs import input_files  # lazy: numpy (see puppet/batch/__init__.py)

    _, tinputs, _ = _scene(job["scene"])  # the template, parsed (and checked unchanged) once per worker
    tpl = template.cached(job["scene"])
    tr = tpl.transfer(job["image"], tolerance=template.TOLERANCE if job["tolerance"] is None else job["tolerance"])
    scene = Scene(tr.scene, job["image"])
    # hashed for --resume: what the client can know without transferring (template files + image)
    hashed = list(tinputs) + [(job["image"], "image")]
    return hashed, hashed + input_files(scene.data, scene_file=False), scene, tr


class _Budgeted:
    """A scene whose ``layers`` solve under the job's budget, in whichever thread asks (the
    export solves frames ahead on a thread of its own; drawing is never budgeted)."""

    def __init__(self, scene, seconds):
        self._scene, self._seconds = scene, seconds

    def __getattr__(self, name):
        return getattr(self._scene, name)

    def layers(self, pose=None, time=None):
        with budget(self._seconds, "the frame's solve"):
            return self._scene.layers(pose, time)


def _make_parent(output: str) -> None:
    parent = os.path.dirname(output.rstrip(os.sep))
    try:
        os.makedirs(parent, exist_ok=True)
    except OSError as e:
        raise SceneError(f"cannot create the folder: {e.strerror or e}", file=parent) from None


def _render(job: dict, scene, inputs):
    """Draw and write the job's output; the posed layers of a pose, time or template job
    (None for an animation)."""
    size = tuple(job["size"]) if job.get("size") else None
    for step in ("before", "after"):  # a folder on the way swapped for a symbolic link since the client checked
        why = unchanged_path(job["output"])
        if why:
            raise SceneError(why, file=job["output"])
        if step == "before":
            _make_parent(job["output"])
    if job["kind"] == "animate":
        from puppet.anim.export import animate_to  # lazy: numpy (see puppet/batch/__init__.py)

        a = job["animate"]
        animate_to(_Budgeted(scene, job.get("budget")), job["output"], fps=a.get("fps"), start=a.get("from"),
                   end=a.get("to"), size=size, wireframe=job.get("wireframe", False),
                   workers=1)  # a batch worker keeps one solver: the batch runs one worker per core
        return None
    with budget(job.get("budget"), "the solve"):
        layers = scene.layers(job.get("pose") if job["kind"] != "time" else None, job.get("time"))
    rgba = scene.draw_layers(layers, size=size, wireframe=job.get("wireframe", False))
    save_png(job["output"], rgba, inputs=inputs)
    return layers


def _room_garment(job: dict, tr, scene, layers, inputs) -> None:
    """``--dressroom``: the matched picture's garment on the template's canvas, and its
    room pictures drawn from the job's own ``layers`` (see :mod:`puppet.batch.dressroom`);
    a failure is the job's."""
    from puppet.batch import dressroom  # lazy: numpy (see puppet/batch/__init__.py)

    try:
        dressroom.write_garment(job, tr, scene, layers, inputs=inputs)
    except SceneError as e:
        raise SceneError(f"dressroom garment: {one_line(e)}") from None


def run_job(job: dict) -> dict:
    """Render one job and write its output (atomically); returns its record::

        {"id": 0, "status": "done" | "failed" | "no-match", "error": None | "one line",
         "inputs": HASH | None, "seconds": 0.12, "worker": "HOST:PID"}
    """
    t0 = time.perf_counter()
    rec = {"id": job["id"], "status": "done", "error": None, "inputs": None, "seconds": 0.0, "worker": _WHO}
    try:
        matched = None
        with budget(job.get("budget"), "loading the scene"):
            if job["kind"] == "template":
                hashed, inputs, scene, matched = _template_scene(job)
            else:
                _, inputs, scene = _scene(job["scene"])
                hashed = inputs
        rec["inputs"] = inputs_digest(spec(job), hashed)
        scene.compositor = compositor()  # this thread's GL context (never the client's)
        layers = _render(job, scene, inputs)
        if job.get("room") and matched is not None:
            _room_garment(job, matched, scene, layers, inputs)
    except (Exception, BudgetExceeded) as e:  # noqa: BLE001 - every failure is the job's; the batch goes on
        rec.update(status="failed", error=one_line(e))
        if type(e).__name__ == "NoMatch":
            rec["status"] = "no-match"
        elif isinstance(e, BudgetExceeded):
            _scenes.pop(job["scene"], None)  # stopped half way: build it again next time
        elif isinstance(e, OSError):
            rec["error"] = f"{getattr(e, 'filename', None) or ''}: {e.strerror or e}".lstrip(": ")
        elif not isinstance(e, SceneError):
            rec["error"] = f"internal error: {type(e).__name__}: {one_line(e)}"
            _scenes.pop(job["scene"], None)
            _reset_compositor()
    rec["seconds"] = round(time.perf_counter() - t0, 4)
    return rec


class Runner:
    """The job runner a batch keeps on each worker (a Dask actor, see
    :mod:`puppet.batch.dispatch`): it runs pieces of jobs in the worker's actor thread,
    which holds the worker's GL context and loaded scenes like a task thread would."""

    def run(self, jobs: list[dict]) -> list[dict]:
        return run_chunk(jobs)

    def warm(self) -> int:
        return warm()


def run_chunk(jobs: list[dict]) -> list[dict]:
    """Run jobs one after the other (a chunk shares the worker's loaded scene); their records."""
    return [run_job(j) for j in jobs]


def warm() -> int:
    """Import what jobs use and create this thread's GL context now (benchmarks: the worker's
    start-up outside the timing, like an in-process loop that has loaded puppet); its pid."""
    import importlib

    for m in ("puppet.api", "puppet.scene.document.core", "puppet.scene.rig.solve", "puppet.scene.rig.build",
              "puppet.deform", "puppet.imaging.io", "puppet.output", "puppet.anim.export"):
        importlib.import_module(m)
    compositor()
    return os.getpid()
