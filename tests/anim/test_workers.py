"""``animate_to(workers=N)`` / ``puppet animate --workers N``: frames solved in N solver
processes (:class:`puppet.anim.solver.SolverPool`) and PNG/GIF frames encoded on N threads
give exactly the frames of one solver, in order; the count is checked and capped; a solver
process that dies stops the export with one line, nothing written and no process left;
frames in flight stay bounded."""
from __future__ import annotations

import dataclasses
import json
import os
import signal
import time

import numpy as np
import pytest
from PIL import Image

import puppet
from puppet.anim import export, options, pipeline, sinks, solver
from puppet.anim.solver import WINDOW, Drawing, SolverLost, SolverPool
from puppet.cli import main
from puppet.errors import SceneError
from tests.cli.outputs_helpers import make_bar

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")


def trex_keys(folder, frames: int = 48, fps: float = 24.0, every: float = 0.1) -> str:
    """A copy of the T-rex whose animation has a key every ``every`` s (its poses in turn,
    eases alternating), ``frames`` frames long."""
    with open(TREX) as f:
        s = json.load(f)
    here = os.path.dirname(TREX)
    for layer in s["layers"]:
        layer["image"] = os.path.join(here, layer["image"])
    poses = ["rest", *s["poses"]]
    end = (frames - 1) / fps
    times = [round(k * every, 6) for k in range(int(end / every) + 1)]
    times += [end] if times[-1] < end - 1e-9 else []
    s["animation"] = {"fps": fps, "keys": [{"time": t, "pose": poses[k % len(poses)],
                                            **({"ease": "smooth"} if k % 2 else {})}
                                           for k, t in enumerate(times)]}
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "trex.json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def files(folder) -> list[bytes]:
    return [open(os.path.join(folder, n), "rb").read() for n in sorted(os.listdir(folder))]


def gif_frames(path) -> list[np.ndarray]:
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append(np.array(im.convert("RGBA")))
    return out


@pytest.fixture
def cap(monkeypatch):
    """The machine runs up to 8 worker processes (so that 3 are started on 2 cores)."""
    monkeypatch.setattr(export, "worker_cap", lambda: (8, 8, 8 << 30))


@pytest.fixture
def drawn(monkeypatch):
    """What each SolverPool.draw answered (True: the solver processes draw and encode)."""
    said = []
    real = SolverPool.draw

    def spy(self, *a, **k):
        said.append(real(self, *a, **k))
        return said[-1]
    monkeypatch.setattr(SolverPool, "draw", spy)
    return said


@dataclasses.dataclass(frozen=True)
class ShipsOtherwiseThere(sinks.PngFile):
    """A PNG folder's frame encoder that, in any process but ``parent`` (a solver process
    that unpickled it), encodes otherwise (``how``: "differs") or cannot (``"raises"``)."""

    parent: int = 0
    how: str = "differs"

    def __call__(self, rgba):
        if os.getpid() == self.parent:
            return super().__call__(rgba)
        if self.how == "raises":
            raise RuntimeError("no encoder here")
        return super().__call__(rgba[::-1].copy())


@pytest.fixture
def children(monkeypatch):
    """The solver processes started (Popen objects), in order."""
    started = []
    real = solver.start_child

    def spy(*a, **k):
        proc, conn = real(*a, **k)
        started.append(proc)
        return proc, conn
    monkeypatch.setattr(solver, "start_child", spy)
    return started


def gone(proc) -> bool:
    """The process has ended and been waited for (no zombie, no orphan)."""
    if proc.poll() is None:
        return False
    try:
        os.kill(proc.pid, 0)
    except ProcessLookupError:
        return True
    return False


def same(a, b) -> bool:
    """Two LayerResults equal in every field (arrays: same type, same numbers)."""
    for k in a.__dataclass_fields__:
        x, y = getattr(a, k), getattr(b, k)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not (isinstance(x, np.ndarray) and isinstance(y, np.ndarray) and x.dtype == y.dtype
                    and np.array_equal(x, y)):
                return False
        elif x != y:
            return False
    return True


# --- the solved frames: no GL ------------------------------------------------------------


@pytest.mark.slow
def test_pool_solves_every_frame_as_this_process_in_order(tmp_path, children):
    """Every field of every layer of every frame equals ``scene.layers(time)``, frames in
    the order asked (here out of time order), with 3 processes."""
    scene = puppet.load_scene(trex_keys(tmp_path, frames=30))
    rate = scene.data.animation.fps
    order = [5, 0, 29, 3, 17, 17, 8, 1, 22, 12, 28, 6]
    pool = SolverPool(scene, 0.0, rate, 3)
    assert pool.start(order[0])
    try:
        got = list(pool.results(order, lambda: False))
    finally:
        pool.close()
    assert len(children) == 3 and all(gone(p) for p in children)
    assert [i for i, _, _ in got] == order
    for i, layers, times in got:
        want = scene.layers(time=i / rate)
        assert set(times) == {"solve"} and times["solve"] > 0 and len(layers) == len(want) == 8
        assert all(same(a, b) for a, b in zip(layers, want)), i
    assert not same(got[0][1][1], got[2][1][1])  # frames 5 and 29 differ: the check can fail


@pytest.mark.slow
@pytest.mark.parametrize("draw", [False, pytest.param(True, marks=pytest.mark.gl)])
def test_frames_in_flight_stay_bounded(tmp_path, draw):
    """200 frames through 2 processes read slowly at first: at most 2 x WINDOW frames are
    ever asked for and not handed on; also while the processes draw and encode them (PNG
    files, each that frame drawn and encoded here)."""
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=20.0))
    pool = SolverPool(scene, 0.0, 10.0, 2)
    assert pool.start(0)
    drawing = Drawing((64, 48), False, scene.background(), sinks.PngFile(1))
    try:
        if draw:
            assert pool.draw(drawing, lambda layers: drawing.composite(scene, layers))
        seen = []
        for k, (i, item, times) in enumerate(pool.results(list(range(200)), lambda: False)):
            if draw and k % 50 == 7:
                assert item == drawing.ship(drawing.composite(scene, scene.layers(time=i / 10.0)))
                assert set(times) == {"solve", "composite", "encode"}
            seen.append(i)
            if k < 5:
                time.sleep(0.2)  # the children finish what they were asked for meanwhile
            assert sum(len(s.sent) for s in pool.solvers) <= 2 * WINDOW
    finally:
        pool.close()
    assert seen == list(range(200))
    assert 2 <= pool.held <= 2 * WINDOW


@pytest.mark.slow
def test_a_child_killed_between_frames_is_one_solver_lost(tmp_path, children):
    """Killed while idle (its pipe closed before it is asked again): SolverLost, not a
    broken pipe, and close() leaves no process."""
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=3.0))
    pool = SolverPool(scene, 0.0, 10.0, 2)
    assert pool.start(0)
    try:
        children[1].kill()
        children[1].wait()
        with pytest.raises(SolverLost, match=r"^a solver process was killed by signal 9 before frame \d+; "):
            list(pool.results(list(range(30)), lambda: False))
    finally:
        pool.close()
    assert all(gone(p) for p in children)


# --- whole exports ------------------------------------------------------------------------


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("name, counts", [("f/", (1, 3)), ("a.gif", (1, 3)), ("a.mp4", (1, 2)), ("a.apng", (1, 2))])
def test_workers_write_what_one_solver_writes(tmp_path, cap, children, drawn, name, counts):
    """PNG frames and the GIF byte for byte, the MP4 and APNG files byte for byte, on the
    T-rex with a key every 0.1 s: one solver on a thread (drawn and encoded here), then 2
    or 3 processes that draw and encode the frames themselves (one count a format, to keep
    the suite's time); the solve stages' seconds
    counted."""
    scene = puppet.load_scene(trex_keys(tmp_path / "s", frames=30))
    outs = []
    for w in counts:
        (tmp_path / str(w)).mkdir()
        out = os.path.join(tmp_path, str(w), name)
        tm = pipeline.Timings()
        assert export.animate_to(scene, out, size=(160, 90), workers=w, timings=tm) == 30
        assert tm["solve"] > 0 and tm["composite"] > 0 and tm["encode"] > 0
        outs.append(files(out) if name.endswith("/") else [open(out, "rb").read()])
    assert len(children) == sum(counts[1:]) and all(gone(p) for p in children)  # none for 1
    assert drawn == [True] * (len(counts) - 1)  # the processes drew
    assert all(o == outs[0] for o in outs[1:])
    if name == "a.gif":
        frames = gif_frames(os.path.join(tmp_path, "1", name))
        assert len(frames) > 10 and not all(np.array_equal(frames[0], f) for f in frames)


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("how", ["differs", "raises"])
def test_processes_that_draw_otherwise_leave_the_drawing_here(tmp_path, cap, children, drawn, monkeypatch, how):
    """Solver processes whose first frame is encoded otherwise than here (or cannot be):
    drawing stays here, they only solve, and the PNG frames are those of one solver."""
    scene = puppet.load_scene(trex_keys(tmp_path / "s", frames=24))
    one = str(tmp_path / "one") + "/"
    assert export.animate_to(scene, one, size=(96, 54), workers=1) == 24
    monkeypatch.setattr(sinks.DirSink, "shipper", lambda self: ShipsOtherwiseThere(self.level, os.getpid(), how))
    two = str(tmp_path / "two") + "/"
    assert export.animate_to(scene, two, size=(96, 54), workers=2) == 24
    assert drawn == [False] and len(children) == 2 and all(gone(p) for p in children)
    assert files(one) == files(two)


def test_what_a_sink_ships_is_written_as_its_own_frames(tmp_path):
    """Each parallel sink writes, byte for byte, the same file from the items its
    shipper made (pickled there and back, as from a solver process) as from frames it
    encodes itself: PNG folder, GIF, MP4 (odd size: padded), WebM (packets), APNG."""
    import pickle

    rng = np.random.default_rng(9)
    frames = [rng.integers(0, 256, (31, 45, 4), dtype=np.uint8) for _ in range(6)]
    frames[2][..., 3] = 255
    palette = sinks.gif_palette(lambda i: frames[i], len(frames), True)[0]
    makers = {"dir": lambda p: (os.mkdir(p), sinks.DirSink(p))[1],
              "gif": lambda p: sinks.GifSink(open(p, "wb"), (45, 31), 12.0, palette, True),
              **{k: (lambda p, k=k: getattr(sinks, f"{k}_sink")(p, (45, 31), 12.0)) for k in ("mp4", "webm", "apng")}}
    for kind, make in makers.items():
        got = []
        for way in ("here", "there"):
            path = str(tmp_path / f"{way}.{kind}")
            sink = make(path)
            ship = pickle.loads(pickle.dumps(sink.shipper()))
            for f in frames:
                sink.write(sink.encode(f) if way == "here" else pickle.loads(pickle.dumps(ship(f))))
            sink.close()
            if kind == "gif":
                sink.stream.fp.close()
            got.append(files(path) if kind == "dir" else _payload(kind, open(path, "rb").read(), path, len(frames)))
        assert got[0] == got[1], kind
    assert sinks.mp4_sink(str(tmp_path / "x.mp4"), (45, 31), 12.0).shipper()(frames[0]).shape == (48, 46)  # YUV 4:2:0


@pytest.mark.gl
@pytest.mark.slow
def test_cli_workers_writes_the_same_frames(tmp_path, cap):
    path = trex_keys(tmp_path / "s", frames=30)
    a, b = str(tmp_path / "a") + "/", str(tmp_path / "b") + "/"
    assert main(["animate", path, "-o", a, "--size", "96x54", "--workers", "1"]) == 0
    assert main(["animate", path, "-o", b, "--size", "96x54", "--workers", "3"]) == 0
    assert files(a) == files(b) and len(files(a)) == 30


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("name", ["f/", "a.mp4"])
def test_a_solver_process_that_dies_stops_the_export(tmp_path, cap, children, drawn, name):
    """A child killed mid-export: one SceneError naming it, no output, no temporary left,
    every child ended and waited for."""
    scene = puppet.load_scene(trex_keys(tmp_path / "s", frames=60))
    out = os.path.join(tmp_path, "o", name)
    os.makedirs(os.path.dirname(out))

    def kill(done, total):
        if done == 4:
            os.kill(children[1].pid, signal.SIGKILL)
    with pytest.raises(SolverLost) as e:
        export.animate_to(scene, out, size=(96, 54), workers=2, progress=kill)
    assert drawn == [True]  # killed while drawing and encoding
    assert "solver process was killed by signal 9" in str(e.value) and "\n" not in str(e.value)
    assert os.listdir(os.path.dirname(out)) == []
    assert len(children) == 2 and all(gone(p) for p in children)


@pytest.mark.gl
@pytest.mark.slow
def test_cli_reports_a_dead_solver_in_one_line(tmp_path, cap, children, monkeypatch, capsys):
    path = trex_keys(tmp_path / "s", frames=60)
    real = pipeline.Progress.update

    def update(self):
        real(self)
        self.n = getattr(self, "n", 0) + 1
        if self.n == 3:
            os.kill(children[0].pid, signal.SIGKILL)
    monkeypatch.setattr(pipeline.Progress, "update", update)
    out = tmp_path / "o.mp4"
    assert main(["animate", path, "-o", str(out), "--size", "96x54", "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("puppet: error: a solver process was killed by signal 9")
    assert not out.exists() and os.listdir(tmp_path) == ["s"]
    assert all(gone(p) for p in children)


# --- the count -----------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["0", "-1", "x", "2.5", "1025", "99999999999999999999"])
def test_bad_workers_on_the_command_line(bar, tmp_path, capsys, value):
    out = tmp_path / "o.gif"
    assert main(["animate", bar, "-o", str(out), "--workers", value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("puppet: error: argument --workers:") and not out.exists()


@pytest.mark.parametrize("value", [0, -1, True, 2.0, "x", 1025, [2]])
def test_bad_workers_in_the_api(bar, tmp_path, value):
    scene = puppet.load_scene(bar)
    with pytest.raises(SceneError) as e:
        export.animate_to(scene, str(tmp_path / "o.gif"), workers=value)
    assert str(e.value).startswith("animate_to: workers=") and "\n" not in str(e.value)
    assert not (tmp_path / "o.gif").exists()


def test_parse_workers():
    assert options.parse_workers("3") == 3 and options.parse_workers(" 12 ") == 12
    assert options.parse_workers(1024) == 1024 and type(options.parse_workers(np.int64(2))) is int
    for bad in ("0", "-2", "", "three", 0, 1025, False, 1.0):
        with pytest.raises(SceneError):
            options.parse_workers(bad)


def test_solver_count(monkeypatch):
    monkeypatch.setattr(export, "worker_cap", lambda: (4, 4, 1 << 30))
    said = []
    assert export.solver_count(None, 10) == 1  # short: solved on a thread
    assert export.solver_count(None, 2 * export.FRAMES_PER_SOLVER) == 2
    assert export.solver_count(None, 1000) == 4
    assert export.solver_count(3, 1000, said.append) == 3 and said == []
    assert export.solver_count(16, 1000, said.append) == 4
    assert len(said) == 1 and "--workers 16: starting 4 solver processes (4 cores, 1.0 GiB" in said[0]
    assert export.solver_count(3, 2) == 2  # never more processes than frames


def test_worker_cap_counts_cores_and_memory(monkeypatch):
    monkeypatch.setattr(options, "default_workers", lambda: 16)
    monkeypatch.setattr(options, "available_memory", lambda: 3 * options.WORKER_BYTES + 5)
    assert options.worker_cap() == (3, 16, 3 * options.WORKER_BYTES + 5)
    monkeypatch.setattr(options, "available_memory", lambda: None)
    assert options.worker_cap()[0] == 16
    monkeypatch.setattr(options, "available_memory", lambda: 0)
    assert options.worker_cap()[0] == 16  # unknown (0 read as unknown, as batch did)


def test_batch_caps_its_workers_alike(monkeypatch):
    from puppet.batch import cluster

    monkeypatch.setattr(cluster, "worker_cap", lambda: (2, 2, 4 << 30))
    said = []
    assert cluster.capped_workers(None, said.append) == 2 and cluster.capped_workers(1, said.append) == 1
    assert cluster.capped_workers(9, said.append) == 2 and len(said) == 1 and said[0].startswith("puppet batch:")


# --- encoding on several threads ------------------------------------------------------------


def test_ahead_keeps_order_and_bounds_what_it_holds():
    taken = []

    def source():
        for i in range(50):
            taken.append(i)
            yield i
    out = []
    for k, v in enumerate(pipeline.ahead(source(), lambda i: i * i, 4)):
        out.append(v)
        assert len(taken) - (k + 1) <= 4
    assert out == [i * i for i in range(50)]


def test_ahead_raises_the_work_error_and_closes_its_source():
    closed = []

    def source():
        try:
            yield from range(20)
        finally:
            closed.append(True)

    def work(i):
        if i == 7:
            raise ValueError("seven")
        return i
    with pytest.raises(ValueError, match="seven"):
        list(pipeline.ahead(source(), work, 3))
    assert closed == [True]


@pytest.mark.parametrize("transparent", [False, True])
def test_parallel_sinks_write_the_same_bytes(tmp_path, transparent):
    """A PNG folder and a GIF fed through 4 encoding threads equal the one-thread files."""
    rng = np.random.default_rng(5)
    frames = [rng.integers(0, 256, (37, 53, 4), dtype=np.uint8) for _ in range(17)]
    for f in frames[::3]:
        f[..., 3] = 255
    palette = sinks.gif_palette(lambda i: frames[i], len(frames), transparent)[0]
    got = {}
    for n in (1, 4):
        folder = tmp_path / f"d{n}"
        folder.mkdir()
        assert sinks.stream(sinks.DirSink(str(folder)), iter(frames), encoders=n) == 17
        with open(tmp_path / f"g{n}.gif", "wb") as fp:
            assert sinks.stream(sinks.GifSink(fp, (53, 37), 10.0, palette, transparent), iter(frames), encoders=n) == 17
        got[n] = files(folder), (tmp_path / f"g{n}.gif").read_bytes()
    assert got[1] == got[4]
    assert np.array_equal(np.array(Image.open(tmp_path / "d4" / "frame_00005.png")), frames[5])


def _old_av_file(tmp, make, frames) -> bytes:
    """The video as the sinks wrote it before frames were converted apart: every frame
    handed to PyAV as RGB(A), converted inside the encoder (the reference)."""
    import av

    sink = make(str(tmp))
    for k, rgba in enumerate(frames):
        pixels = np.ascontiguousarray(rgba if sink.alpha else sinks.flatten(rgba))
        if any(sink.pad):
            pixels = np.pad(pixels, ((0, sink.pad[0]), (0, sink.pad[1]), (0, 0)), mode="edge")
        frame = av.VideoFrame.from_ndarray(pixels, format="rgba" if sink.alpha else "rgb24")
        frame.pts = k
        for pkt in sink.stream.encode(frame):
            sink.box.mux(pkt)
    sink.close()
    return tmp.read_bytes()


@pytest.mark.parametrize("kind", ["mp4", "webm", "apng"])
def test_video_sinks_write_what_pyav_converting_wrote(tmp_path, kind):
    """MP4 (odd size: padded), WebM with alpha and APNG, one encoding thread and three:
    byte for byte the file of the reference (PyAV converting inside the encoder)."""
    make = {"mp4": lambda p: sinks.mp4_sink(p, (45, 31), 12.0), "webm": lambda p: sinks.webm_sink(p, (45, 31), 12.0),
            "apng": lambda p: sinks.apng_sink(p, (45, 31), 12.0)}[kind]
    yy, xx = np.mgrid[0:31, 0:45]
    frames = []
    for k in range(9):
        f = np.zeros((31, 45, 4), np.uint8)
        f[..., 0], f[..., 1], f[..., 2] = (xx * 5 + 20 * k) % 256, (yy * 8) % 256, 90
        f[..., 3] = np.where((xx - 4 * k) % 45 < 20, 255, 60)
        frames.append(f)
    want = _payload(kind, _old_av_file(tmp_path / f"ref.{kind}", make, frames), tmp_path / f"ref.{kind}")
    for n in (1, 3):
        out = tmp_path / f"new{n}.{kind}"
        assert sinks.stream(make(str(out)), iter(frames), encoders=n) == 9
        assert _payload(kind, out.read_bytes(), out) == want, n


def _payload(kind, data: bytes, path, frames: int = 9):
    """The file's bytes; for WebM (whose Matroska header holds a random segment UID) the
    bytes of every packet of its video stream."""
    if kind != "webm":
        return data
    import av

    with av.open(str(path)) as box:
        packets = [bytes(p) for p in box.demux(box.streams.video[0]) if p.size]
    assert len(packets) == frames
    return packets


def test_batch_animation_jobs_keep_one_solver(tmp_path, monkeypatch):
    """A batch worker is one process per core already (and budgets its solves on its own
    threads): its animation jobs ask for one solver."""
    from puppet.batch import work

    asked = []
    monkeypatch.setattr(export, "animate_to", lambda scene, out, **kw: asked.append(kw))
    job = {"kind": "animate", "output": str(tmp_path / "o" / "a.gif"), "animate": {"fps": 10}}
    work._render(job, object(), ())
    assert len(asked) == 1 and asked[0]["workers"] == 1


def _children_of(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (read from /proc)."""
    found = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat") as f:
                    if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                        found.append(int(name))
            except (OSError, ValueError, IndexError):
                pass
    return found


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:  # a zombie is not alive (its parent has gone: init reaps it)
        return f.read().rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_mid_export_stops_every_solver_process(tmp_path, sig):
    """`puppet animate --workers 2` stopped mid-export: nothing written, and its two solver
    processes end with it."""
    import subprocess
    import sys

    from tests.cli.test_signals import _wait_for_temp

    if options.worker_cap()[0] < 2:
        pytest.skip("this machine runs one solver process")
    scene = make_bar(tmp_path / "s", seconds=1000.0)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "puppet", "animate", scene, "-o", str(out_dir / "o.mp4"),
                             "--workers", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=ROOT), cwd=ROOT)
    try:
        _wait_for_temp(proc, out_dir)
        kids = _children_of(proc.pid)
        assert len(kids) == 2  # the two solver processes
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode in (-sig, 130), (proc.returncode, err)
    assert os.listdir(out_dir) == []
    end = time.monotonic() + 10
    while any(_alive(k) for k in kids) and time.monotonic() < end:
        time.sleep(0.05)
    assert not any(_alive(k) for k in kids)
