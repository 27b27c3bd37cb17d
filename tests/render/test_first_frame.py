"""The first frame allocates its render targets once: ``Compositor.reserve`` makes the
targets ``render`` then draws into, and a scene's size check uses them instead of a
throwaway framebuffer of the frame's size."""
from __future__ import annotations

import numpy as np
import pytest

moderngl = pytest.importorskip("moderngl")

import puppet  # noqa: E402
import puppet.render.compositor as compositor  # noqa: E402
from puppet.errors import SceneError  # noqa: E402
from puppet.render.compositor import Compositor  # noqa: E402
from tests.cli.outputs_helpers import make_bar  # noqa: E402
from tests.render.scenes import CANVAS, translucent_stack  # noqa: E402

pytestmark = pytest.mark.gl


@pytest.fixture()
def comp():
    c = Compositor()
    yield c
    c.release()


@pytest.mark.parametrize("background, dtype", [((0, 0, 0, 0), "f2"), ((10, 20, 30, 255), "f1")])
def test_reserve_makes_the_targets_render_draws_into(comp, background, dtype):
    comp.reserve(CANVAS, background=background)
    (key, targets), = comp._targets.items()
    assert key == (CANVAS, dtype, None) and targets.dtype == dtype
    fresh = Compositor()
    try:
        want = fresh.render(translucent_stack(), CANVAS, background=background)
    finally:
        fresh.release()
    got = comp.render(translucent_stack(), CANVAS, background=background)
    assert list(comp._targets.items()) == [(key, targets)]  # the same objects, nothing allocated again
    assert np.array_equal(got, want)


def test_a_failed_reservation_keeps_nothing(comp, monkeypatch):
    real = compositor.FrameTargets

    def leaves_an_error(ctx, *a, **k):
        targets = real(ctx, *a, **k)
        ctx.texture((1 << 20, 1), 4)  # GL_INVALID_VALUE (too wide); a driver out of memory leaves its own error
        return targets

    monkeypatch.setattr(compositor, "FrameTargets", leaves_an_error)
    with pytest.raises(moderngl.Error):
        comp.reserve(CANVAS)
    assert comp._targets == {}
    monkeypatch.setattr(compositor, "FrameTargets", real)
    assert comp.render(translucent_stack(), CANVAS).shape == (CANVAS[1], CANVAS[0], 4)


def _counting(monkeypatch, name: str) -> list:
    calls = []
    real = getattr(moderngl.Context, name)

    def counted(self, *a, **k):
        calls.append(a)
        return real(self, *a, **k)
    monkeypatch.setattr(moderngl.Context, name, counted)
    return calls


def test_a_scenes_first_frame_allocates_no_throwaway_framebuffer(tmp_path, monkeypatch):
    s = puppet.load_scene(make_bar(tmp_path / "s"))
    try:
        colour, depth = _counting(monkeypatch, "renderbuffer"), _counting(monkeypatch, "depth_renderbuffer")
        s.render(size=(90, 30))
        s.render(size=(90, 30))
        assert colour == [] and len(depth) == 1  # the compositor's own targets only, once
    finally:
        s.close()


def test_a_scene_refuses_a_frame_its_targets_cannot_hold_in_one_line(tmp_path, monkeypatch):
    def fail(*a, **k):
        raise moderngl.Error("the framebuffer is not complete (INCOMPLETE_ATTACHMENT)")

    s = puppet.load_scene(make_bar(tmp_path / "s"))
    try:
        monkeypatch.setattr(compositor, "FrameTargets", fail)
        with pytest.raises(SceneError, match="draw: a frame of 90x30 pixels cannot be drawn: OpenGL cannot "
                                             "allocate a 90x30 frame .the framebuffer is not complete"):
            s.render(size=(90, 30))
        assert s.compositor._targets == {}
    finally:
        s.close()


def test_the_kbuffer_colours_need_no_initial_contents(comp):
    """The packed colours start undefined (not uploaded): whatever they hold, a frame whose
    stamps are stale reads none of it. Random bytes there change nothing."""
    if comp.render(translucent_stack(), CANVAS) is None or comp.last_method != "kbuffer":
        pytest.skip("no K-buffer on this context")
    want = comp.render(translucent_stack(), CANVAS)
    (targets,) = comp._targets.values()
    colours = targets.kbuffer_fbo.color_attachments[1]
    assert colours.dtype == "u4" and colours.components == 4
    rng = np.random.default_rng(5)
    for _ in range(3):
        colours.write(rng.integers(0, 1 << 32, CANVAS[0] * CANVAS[1] * 4, dtype=np.uint32))
        got = comp.render(translucent_stack(), CANVAS)
        assert comp.last_method == "kbuffer" and np.array_equal(got, want)


@pytest.mark.parametrize("channels", [4, 3])
def test_a_saved_png_decodes_to_the_same_pixels(comp, tmp_path, channels):
    """save_png's row filter is a choice of speed and size only: Pillow reads back every
    pixel of a render and of noise (odd sizes, a strided view, RGB and RGBA)."""
    from PIL import Image

    from puppet.output import save_png

    rng = np.random.default_rng(7)
    frames = [comp.render(translucent_stack(), CANVAS, size=(65, 47)),
              rng.integers(0, 256, (31, 77, 4), dtype=np.uint8),
              rng.integers(0, 256, (20, 50, 4), dtype=np.uint8)[:, ::2]]
    for k, frame in enumerate(frames):
        frame = frame[..., :channels]
        path = str(tmp_path / f"f{k}.png")
        save_png(path, frame)
        with Image.open(path) as im:
            assert im.mode == ("RGBA" if channels == 4 else "RGB")
            assert np.array_equal(np.asarray(im), frame)


def test_puppet_render_allocates_its_frame_once(tmp_path, monkeypatch):
    from puppet.cli import main

    scene = make_bar(tmp_path / "s")
    colour, depth = _counting(monkeypatch, "renderbuffer"), _counting(monkeypatch, "depth_renderbuffer")
    assert main(["render", scene, "-o", str(tmp_path / "o.png"), "--size", "90x30"]) == 0
    assert colour == [] and len(depth) == 1  # checked by allocating the frame's own targets
