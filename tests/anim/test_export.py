"""Animation export end to end (real GL, real encoders): the streamed GIF shows the same
frames as the PNG folder, frames are streamed, the pipelined export writes exactly what
the sequential one writes, and a failure in any stage leaves nothing behind."""
from __future__ import annotations

import errno
import os

import numpy as np
import pytest
from PIL import Image

import puppet
from puppet.anim import export, pipeline, sinks
from puppet.cli import main
from puppet.errors import SceneError
from tests.cli.outputs_helpers import make_bar

pytestmark = pytest.mark.gl


def _gif_frames(path):
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append((np.array(im.convert("RGB")).astype(int), im.info["duration"]))
    return out


def pngs(folder):
    return [np.array(Image.open(os.path.join(folder, n))) for n in sorted(os.listdir(folder))]


def test_gif_matches_the_png_frames(bar, tmp_path, monkeypatch):
    assert main(["animate", bar, "-o", str(tmp_path / "f") + "/"]) == 0
    frames = pngs(tmp_path / "f")
    assert main(["animate", bar, "-o", str(tmp_path / "a.gif")]) == 0
    gif = _gif_frames(tmp_path / "a.gif")
    assert len(gif) == len(frames) == 11 and sum(ms for _, ms in gif) == 1100
    for (rgb, _), rgba in zip(gif, frames):
        want = export.flatten(rgba).astype(int)
        assert np.abs(rgb - want).mean() < 1.5 and np.abs(rgb - want).max() <= 64
    monkeypatch.setattr(sinks, "GIF_SAMPLE_CACHE", 0)  # the sample frames are drawn again
    assert main(["animate", bar, "-o", str(tmp_path / "b.gif")]) == 0
    assert (tmp_path / "a.gif").read_bytes() == (tmp_path / "b.gif").read_bytes()


@pytest.mark.parametrize("threads", [False, True])
def test_frames_are_streamed(tmp_path, threads, monkeypatch):
    """Frame i is solved only once frames up to i - (a few) are on disk: memory stays flat."""
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=4.0))  # 41 frames
    on_disk = []
    real = type(scene).layers

    def layers(self, *a, **k):
        tmp = [n for n in os.listdir(tmp_path) if n.endswith(".tmp")]
        on_disk.append(len(os.listdir(tmp_path / tmp[0])) if tmp else -1)
        return real(self, *a, **k)

    monkeypatch.setattr(type(scene), "layers", layers)
    assert export.animate_to(scene, str(tmp_path / "frames") + "/", threads=threads) == 41
    ahead = [i - k for i, k in enumerate(on_disk)]
    if threads:  # queues of DEPTH between the stages, one frame in each stage
        assert max(ahead) <= 2 * pipeline.DEPTH + 3, ahead
    else:
        assert ahead == [0] * 41


@pytest.mark.parametrize("name", ["f/", "a.gif", "a.png", "a.apng"])
def test_pipelined_output_equals_sequential(tmp_path, name):
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=2.0))
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    ta, tb = pipeline.Timings(), pipeline.Timings()
    assert export.animate_to(scene, os.path.join(a, name), threads=True, timings=ta) == 21
    assert export.animate_to(scene, os.path.join(b, name), threads=False, timings=tb) == 21
    assert set(ta) >= {"solve", "composite", "encode"} and set(tb) == {"solve", "composite", "encode"}
    if name.endswith("/"):
        fa, fb = pngs(a / "f"), pngs(b / "f")
        assert len(fa) == 21 and all(np.array_equal(x, y) for x, y in zip(fa, fb))
        assert any(not np.array_equal(fa[0], x) for x in fa[1:])  # the frames do move
    else:
        assert (a / name).read_bytes() == (b / name).read_bytes()


def test_pipelined_mp4_frames_equal_sequential(tmp_path):
    import av

    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=1.0))
    out = []
    for threads in (True, False):
        path = str(tmp_path / f"{threads}.mp4")
        export.animate_to(scene, path, threads=threads)
        with av.open(path) as box:
            out.append([f.to_ndarray(format="rgb24") for f in box.decode(video=0)])
    assert len(out[0]) == len(out[1]) == 11
    assert all(np.array_equal(x, y) for x, y in zip(*out))


def _leftovers(folder):
    return [n for n in os.listdir(folder) if n != "s"]


@pytest.mark.parametrize("threads", [False, True])
@pytest.mark.parametrize("name", ["f/", "a.mp4", "a.webm", "a.png"])
def test_a_failing_solve_leaves_nothing(tmp_path, monkeypatch, name, threads):
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=3.0))
    real, calls = type(scene).layers, []

    def layers(self, *a, **k):
        calls.append(1)
        if len(calls) == 12:
            raise SceneError("frame 11 cannot be solved", file="x.json")
        return real(self, *a, **k)

    monkeypatch.setattr(type(scene), "layers", layers)
    with pytest.raises(SceneError, match="frame 11 cannot be solved"):
        export.animate_to(scene, os.path.join(tmp_path, name), threads=threads)
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("threads", [False, True])
def test_a_failing_encoder_is_an_output_error(tmp_path, monkeypatch, threads):
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=3.0))
    real, calls = sinks.DirSink.add, []

    def add(self, rgba):
        calls.append(1)
        if len(calls) == 7:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(self, rgba)

    monkeypatch.setattr(sinks.DirSink, "add", add)
    with pytest.raises(SceneError, match="No space left on device"):
        export.animate_to(scene, str(tmp_path / "f") + "/", threads=threads)
    assert _leftovers(tmp_path) == []


def test_progress_bar_on_request_only(tmp_path, capsys):
    scene = puppet.load_scene(make_bar(tmp_path / "s"))
    export.animate_to(scene, str(tmp_path / "a.gif"), progress=True)
    err = capsys.readouterr().err
    assert "11/11" in err and "frame/s" in err and "100%" in err
    export.animate_to(scene, str(tmp_path / "b.gif"), progress=False)
    assert capsys.readouterr().err == ""


def test_cli_shows_no_bar_off_a_terminal(bar, tmp_path, capfd):
    assert main(["animate", bar, "-o", str(tmp_path / "a.gif")]) == 0
    assert capfd.readouterr().err == ""


@pytest.mark.parametrize("name", ["f/", "a.mp4"])
@pytest.mark.slow
def test_solver_process_gives_the_same_frames(tmp_path, name):
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=2.0))
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    assert export.animate_to(scene, os.path.join(a, name), solver="process") == 21
    assert export.animate_to(scene, os.path.join(b, name), threads=False) == 21
    if name.endswith("/"):
        fa, fb = pngs(a / "f"), pngs(b / "f")
        assert all(np.array_equal(x, y) for x, y in zip(fa, fb))
    else:
        assert (a / name).read_bytes() == (b / name).read_bytes()


@pytest.mark.slow
def test_solver_process_is_used_and_stopped(tmp_path, monkeypatch):
    from puppet.anim import solver

    started, closed = [], []
    real_start, real_close = solver.ProcessSolver.start, solver.ProcessSolver.close
    monkeypatch.setattr(solver.ProcessSolver, "start", lambda self, first, **k: started.append(
        real_start(self, first, **k)) or started[-1])
    monkeypatch.setattr(solver.ProcessSolver, "close", lambda self: closed.append(self.proc) or real_close(self))
    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=2.0))
    export.animate_to(scene, str(tmp_path / "f") + "/", solver="process")
    assert started == [True] and closed and closed[0].poll() is not None  # the child has ended


@pytest.mark.slow
def test_solver_process_falls_back_when_the_scene_differs_from_its_file(tmp_path):
    """An edit the child cannot see (here: a solve patched in this process only) is caught
    on the first frame; the export then solves on a thread and matches the sequential one."""
    from puppet.anim.solver import ProcessSolver

    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=2.0))
    real = type(scene).layers

    def shifted(self, *a, **k):
        out = real(self, *a, **k)
        for r in out:
            r.deformed = r.deformed + 3.0
        return out

    scene.layers = shifted.__get__(scene)
    p = ProcessSolver(scene, 0.0, 10.0)
    assert p.start(0) is False and p.proc is None
    a, b = tmp_path / "a", tmp_path / "b"
    export.animate_to(scene, str(a) + "/", solver="process")
    export.animate_to(scene, str(b) + "/", threads=False)
    assert all(np.array_equal(x, y) for x, y in zip(pngs(a), pngs(b)))


@pytest.mark.slow
def test_solver_process_error_is_raised(tmp_path):
    """A frame the child cannot solve (a negative time) raises the child's user error here."""
    from puppet.anim.solver import ProcessSolver

    scene = puppet.load_scene(make_bar(tmp_path / "s", seconds=2.0))
    with pytest.raises(SceneError) as want:
        scene.layers(time=-5.0)
    p = ProcessSolver(scene, 0.0, 10.0)
    assert p.start(0)
    try:
        got = list(p.results([3, 4], lambda: False))
        assert [i for i, _, _ in got] == [3, 4]
        assert np.array_equal(got[1][1][0].deformed, scene.layers(time=0.4)[0].deformed)
        with pytest.raises(SceneError) as e:
            list(p.results([-50], lambda: False))
        assert str(e.value) == str(want.value)
    finally:
        p.close()
    assert p.proc is None


@pytest.mark.parametrize("winsize", [None, (30, 100)])
def test_cli_shows_the_bar_on_a_terminal(bar, tmp_path, winsize):
    """On a terminal (a pty, sized or reporting no size) the bar shows frames, rate and ETA."""
    import fcntl
    import pty
    import struct
    import sys
    import termios

    from tests.conftest import ROOT

    pid, fd = pty.fork()
    if pid == 0:  # the child: the real command on the pty
        try:
            if winsize:
                fcntl.ioctl(0, termios.TIOCSWINSZ, struct.pack("HHHH", *winsize, 0, 0))
            os.chdir(ROOT)
            os.execv(sys.executable, [sys.executable, "-m", "puppet", "animate", bar, "-o", str(tmp_path / "a.gif")])
        finally:
            os._exit(99)
    out = b""
    while True:
        try:
            chunk = os.read(fd, 4096)
        except OSError:
            break
        if not chunk:
            break
        out += chunk
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, out
    last = out.decode().replace("\r", "\n").split("\n")
    shown = [s for s in last if "11/11" in s]
    assert shown and "100%" in shown[-1] and "frame/s" in shown[-1] and "<00:00" in shown[-1], out


@pytest.mark.slow
def test_solver_process_does_not_rerun_the_callers_script(tmp_path):
    """A script without a ``__main__`` guard runs once: the solver child does not import it
    (as multiprocessing's spawn would, exporting the whole animation a second time)."""
    import subprocess
    import sys

    from tests.conftest import ROOT

    scene = make_bar(tmp_path / "s", seconds=2.0)
    log = tmp_path / "runs.txt"
    script = tmp_path / "export.py"
    script.write_text(
        "from puppet.anim import export\nimport puppet\n"
        f"open({str(log)!r}, 'a').write('run\\n')\n"
        f"export.animate_to(puppet.load_scene({scene!r}), {str(tmp_path / 'a.mp4')!r}, solver='process')\n"
        "from puppet.anim import solver\n"
        f"open({str(log)!r}, 'a').write('done\\n')\n")
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                       env=dict(os.environ, PYTHONPATH=ROOT))
    assert r.returncode == 0, r.stderr
    assert log.read_text() == "run\ndone\n"
    assert (tmp_path / "a.mp4").stat().st_size > 0
