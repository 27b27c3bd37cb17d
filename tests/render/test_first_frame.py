"""The first frame allocates its render targets once: ``Compositor.reserve`` makes the
targets ``render`` then draws into, and a scene's size check uses them instead of a
throwaway framebuffer of the frame's size."""
from __future__ import annotations

import json
import os
import threading

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


# -- a scene's first frame: its targets made while the rig is built ----------------------
def _bar(tmp_path, background=None) -> str:
    path = make_bar(tmp_path / "s")
    if background is not None:
        doc = json.loads(open(path).read())
        doc["background"] = background
        with open(path, "w") as f:
            json.dump(doc, f)
    return path


def _first_render(path, monkeypatch, *, overlap: bool, pose=None, size=None):
    """(frame, threads that built the rig, the compositor's targets after the frame)."""
    s = puppet.load_scene(path)
    threads = []
    real = s.rig.build

    def build(data, **kw):
        threads.append(threading.current_thread().name)
        return real(data, **kw)

    monkeypatch.setattr(s.rig, "build", build)
    if not overlap:
        monkeypatch.setattr(s, "_first_frame_size", lambda size: None)
    try:
        frame = s.render(pose, size=size)
        return frame, threads, list(s.compositor._targets.values())
    finally:
        s.close()


@pytest.mark.parametrize("background", [None, [0, 0, 0, 0]])
@pytest.mark.parametrize("size", [None, (60, 20)])
def test_a_first_render_builds_the_rig_beside_its_targets_and_draws_the_same_bits(tmp_path, monkeypatch,
                                                                                  background, size):
    path = _bar(tmp_path, background)
    want, threads, _ = _first_render(path, monkeypatch, overlap=False, pose="bend", size=size)
    assert threads == ["MainThread"]
    got, threads, targets = _first_render(path, monkeypatch, overlap=True, pose="bend", size=size)
    assert threads == ["puppet-first-layers"]
    assert np.array_equal(got, want)
    (t,) = targets  # made once, before the frame, all of them: the K-buffer's, the straight output's
    assert t.kbuffer_fbo is not None and (t.out_fbo is not None) == (background is not None)


def test_a_first_render_reports_the_layers_failure_first(tmp_path, monkeypatch):
    path = _bar(tmp_path)
    with pytest.raises(SceneError, match="nope"):
        _first_render(path, monkeypatch, overlap=True, pose="nope")
    import puppet.render.context as context

    monkeypatch.setattr(context, "output_size_problem", lambda *a, **k: "no memory")
    with pytest.raises(SceneError, match="nope"):  # both fail: as when the layers came first
        _first_render(path, monkeypatch, overlap=True, pose="nope")
    with pytest.raises(SceneError, match="cannot be drawn: no memory"):
        _first_render(path, monkeypatch, overlap=True)


@pytest.mark.parametrize("background, dtype", [((0, 0, 0, 0), "f2"), ((10, 20, 30, 255), "f1")])
def test_a_full_reservation_makes_every_target_of_the_frame(comp, background, dtype, monkeypatch):
    comp.reserve(CANVAS, background=background, full=True)
    (targets,) = comp._targets.values()
    assert targets.kbuffer_fbo is not None and (targets.out_fbo is not None) == (dtype == "f2")
    made = [_counting(monkeypatch, "texture"), _counting(monkeypatch, "external_texture")]
    fresh = Compositor()
    try:
        want = fresh.render(translucent_stack(), CANVAS, background=background)
    finally:
        fresh.release()
    for calls in made:
        del calls[:]
    got = comp.render(translucent_stack(), CANVAS, background=background)
    assert np.array_equal(got, want) and comp.last_method == "kbuffer"
    assert [len(calls) for calls in made] == [len(translucent_stack()), 0]  # the layers' textures only


@pytest.mark.parametrize("background", [(0, 0, 0, 0), (250, 250, 240, 255)])
def test_targets_made_without_the_gil_draw_as_moderngl_s(monkeypatch, background):
    deleted = []
    a, b = Compositor(), Compositor()
    try:
        assert a._unlocked is not None
        real = a._unlocked.delete
        monkeypatch.setattr(a._unlocked, "delete", lambda names: (deleted.extend(names), real(names)))
        b._unlocked = None  # the moderngl path
        layers = translucent_stack(3)
        want = b.render(layers, CANVAS, background=background)
        got = a.render(layers, CANVAS, background=background)
        assert a.last_method == b.last_method == "kbuffer" and np.array_equal(got, want)
        (t,) = a._targets.values()  # composite, K-buffer, straight output: all made through ctypes
        names = list(t._names)
        made = [t.main, *t.kbuffer_fbo.color_attachments[1:], *(t.out_fbo.color_attachments if t.out_fbo else [])]
        assert sorted(x.glo for x in made) == sorted(names) and len(names) == (4 if background[3] < 255 else 3)
        assert not list(b._targets.values())[0]._names
    finally:
        a.release()
        b.release()
    assert deleted == names  # deleted with the targets (an external texture's release does not)


def test_a_callers_context_gets_no_unlocked_calls():
    ctx = moderngl.create_standalone_context(require=430, backend="egl")
    try:
        with ctx:
            c = Compositor(ctx)
            assert c._unlocked is None
            c.release()
    finally:
        ctx.release()


def test_an_unreadable_source_fails_as_it_did(tmp_path, monkeypatch):
    path = _bar(tmp_path / "a")
    doc = json.loads(open(path).read())
    doc.pop("canvas", None)
    doc["source"] = "source.png"
    with open(os.path.join(os.path.dirname(path), "source.png"), "wb") as f:
        f.write(b"not a png")
    with open(path, "w") as f:
        json.dump(doc, f)
    messages = []
    for overlap in (False, True):
        with pytest.raises(SceneError) as err:
            _first_render(path, monkeypatch, overlap=overlap)
        messages.append(str(err.value))
    assert messages[0] == messages[1] and "source" in messages[0]
