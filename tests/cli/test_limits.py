"""Sizes and lengths a user asks for are bounded before anything is drawn: frame count,
frame rate, output pixels and the GL context's largest framebuffer."""
from __future__ import annotations

import json
import os
import time

import moderngl
import pytest

from puppet.anim.export import MAX_FRAMES, frame_count
from puppet.cli import MAX_PIXELS, main
from puppet.errors import SceneError
from puppet.render.context import max_output_size, output_size_problem
from tests.cli.outputs_helpers import cli, make_bar, one_error_line, snapshot

pytestmark = pytest.mark.gl


def _edit(scene, change):
    with open(scene) as f:
        s = json.load(f)
    change(s)
    with open(scene, "w") as f:
        json.dump(s, f)


@pytest.mark.parametrize("args,words", [
    (["--fps", "240", "--to", "1000"], f"more than {MAX_FRAMES} frames"),
    (["--to", "1e300"], f"more than {MAX_FRAMES} frames"),
    (["--from", "2", "--to", "1"], "before --from"),
    (["--fps", "0.001"], "fps must be in 0.01..240"),
    (["--fps", "1e-300"], "fps must be in 0.01..240"),
    (["--size", "16384x16384"], f"at most {MAX_PIXELS} pixels"),
    (["--size", "16385x10"], "1..16384"),
])
def test_animate_limits_are_checked_before_drawing(tmp_path, args, words):
    scene = make_bar(tmp_path / "s")
    before = snapshot(tmp_path)
    t0 = time.monotonic()
    line = one_error_line(cli("animate", scene, "-o", tmp_path / "o.gif", *args))
    assert words in line, line
    assert time.monotonic() - t0 < 60  # refused up front, not after drawing (generous: a loaded machine)
    assert snapshot(tmp_path) == before


def test_scene_whose_animation_is_too_long(tmp_path):
    """Keys up to 10^6 s at the scene's 24 fps: 24 million frames, refused without flags."""
    scene = make_bar(tmp_path / "s", seconds=1e6, fps=24)
    line = one_error_line(cli("animate", scene, "-o", str(tmp_path / "frames") + "/"))
    assert f"more than {MAX_FRAMES} frames" in line and "--from/--to" in line
    assert sorted(os.listdir(tmp_path)) == ["s"]


def test_scene_fps_below_the_limit_names_the_scene(tmp_path):
    scene = make_bar(tmp_path / "s", fps=1e-9)
    line = one_error_line(cli("animate", scene, "-o", tmp_path / "o.mp4"))
    assert f"{scene}: animation.fps: 1e-09 fps is outside 0.01..240" in line
    assert sorted(os.listdir(tmp_path)) == ["s"]


def test_canvas_too_large_without_size(tmp_path):
    scene = make_bar(tmp_path / "s")
    _edit(scene, lambda s: s.update(canvas=[16384, 16384]))
    for command, out in (("render", "o.png"), ("animate", "o.mp4")):
        line = one_error_line(cli(command, scene, "-o", tmp_path / out))
        assert "the canvas (16384x16384; give a smaller --size)" in line and f"at most {MAX_PIXELS}" in line
    assert sorted(os.listdir(tmp_path)) == ["s"]


def test_frame_count_is_exact_and_bounded():
    assert frame_count(0.0, 1.0, 10.0) == 11
    assert frame_count(0.5, 1.0, 4.0) == 3
    assert frame_count(0.0, 0.3, 10.0) == 4  # 0.3 * 10 is 2.9999999999999996
    assert frame_count(2.0, 2.0, 30.0) == 1
    assert frame_count(0.0, (MAX_FRAMES - 1) / 10.0, 10.0) == MAX_FRAMES
    with pytest.raises(SceneError, match="more than"):
        frame_count(0.0, MAX_FRAMES / 10.0, 10.0)
    with pytest.raises(SceneError, match="more than"):
        frame_count(0.0, 1e308, 240.0)  # the span overflows to inf


# -- the GL context's limits --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ctx():
    from puppet.render.context import create_context

    c = create_context()
    yield c
    c.release()


def test_max_output_size_comes_from_the_context(ctx):
    limit = max_output_size(ctx)
    with ctx:
        info = ctx.info
    assert limit == min(info["GL_MAX_RENDERBUFFER_SIZE"], info["GL_MAX_TEXTURE_SIZE"], *info["GL_MAX_VIEWPORT_DIMS"])
    assert output_size_problem(ctx, (64, 48)) is None
    assert output_size_problem(ctx, (limit, 1)) is None
    msg = output_size_problem(ctx, (limit + 1, 1))
    assert msg == f"this machine's OpenGL draws at most {limit}x{limit}"
    with ctx:
        assert ctx.error == "GL_NO_ERROR"  # the probe leaves no error behind


class _StubContext:
    """A context whose limits and allocation result we choose (what a small GPU reports)."""

    def __init__(self, limit, fail=None):
        self.info = {"GL_MAX_RENDERBUFFER_SIZE": limit, "GL_MAX_TEXTURE_SIZE": limit * 2,
                     "GL_MAX_VIEWPORT_DIMS": (limit * 2, limit * 2)}
        self.fail = fail
        self.released = 0
        self.error = "GL_NO_ERROR"

    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False

    def _obj(self):
        if self.fail == "raise":
            raise moderngl.Error("the framebuffer is not complete (INCOMPLETE_ATTACHMENT)")
        if self.fail == "oom":
            self.error = "GL_OUT_OF_MEMORY"
        ctx = self

        class Obj:
            def release(self):
                ctx.released += 1
        return Obj()

    def renderbuffer(self, size, components):
        return self._obj()

    def depth_renderbuffer(self, size):
        return self._obj()

    def framebuffer(self, color, depth):
        return self._obj()


def test_output_size_problem_with_a_small_gpu():
    small = _StubContext(4096)
    assert max_output_size(small) == 4096
    assert output_size_problem(small, (4096, 4096)) is None and small.released == 3
    assert output_size_problem(small, (4097, 10)) == "this machine's OpenGL draws at most 4096x4096"
    assert "cannot allocate a 4000x4000 frame (GL_OUT_OF_MEMORY)" in output_size_problem(_StubContext(4096, "oom"),
                                                                                          (4000, 4000))
    assert "framebuffer is not complete" in output_size_problem(_StubContext(4096, "raise"), (4000, 4000))


def test_failed_gl_allocation_while_drawing_is_a_user_error(tmp_path, monkeypatch, capsys):
    """The compositor failing to allocate its targets is reported as one line, exit 2."""
    from puppet.render.compositor import Compositor

    def fail(*a, **k):
        raise moderngl.Error("the framebuffer is not complete (INCOMPLETE_ATTACHMENT)")

    monkeypatch.setattr(Compositor, "render", fail)
    scene = make_bar(tmp_path / "s")
    for command, out in (("render", "o.png"), ("animate", "o.gif")):
        assert main([command, scene, "-o", str(tmp_path / out), "--size", "300x100"]) == 2
        line, = capsys.readouterr().err.strip().splitlines()
        assert line.startswith("puppet: error: OpenGL could not allocate a 300x100 frame"), line
        assert "give a smaller --size" in line
    assert sorted(os.listdir(tmp_path)) == ["s"]
