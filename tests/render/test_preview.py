"""The compositor's drag-preview frames (``preview=True``: the opaque pass as always, soft
edges blended unsorted into an RGBA8 composite, made straight on the CPU) against the CPU
reference where one translucent fragment at most covers a pixel or the layers' depths do
not cross; alpha against it everywhere (``over`` gives the same alpha in any order); the
CPU's straight alpha against the shader's rounding; exact frames unchanged by preview
frames between them."""
from __future__ import annotations

import numpy as np
import pytest

moderngl = pytest.importorskip("moderngl")

from puppet.render.compositor import Compositor  # noqa: E402
from puppet.render.layers import unpremultiply_soft  # noqa: E402
from tests.render import reference  # noqa: E402
from tests.render.scenes import (CANVAS, crossing_scene, disc_over, random_scene,  # noqa: E402
                                 translucent_stack)
from tests.render.test_compositor import premultiplied_levels  # noqa: E402

#: Grey levels between a preview and the reference (premultiplied): an RGBA8 composite
#: rounds once more than the half-float one of an exact frame.
TOL = 3


@pytest.fixture(scope="module")
def comp():
    c = Compositor()
    yield c
    c.release()


def _diff(a, b) -> np.ndarray:
    return np.abs(premultiplied_levels(a) - premultiplied_levels(b))


@pytest.mark.gl
@pytest.mark.parametrize("background", [(0, 0, 0, 0), (255, 255, 255, 255), (30, 60, 90, 128)])
def test_one_soft_edge_over_a_layer_matches_reference(comp, background):
    layers = disc_over((40, 90, 220), (250, 150, 20), transparent=(0, 0, 0))
    gl = comp.render(layers, (48, 40), background=background, preview=True)
    ref = reference.reference_composite(layers, (48, 40), background=background)
    assert gl.shape == ref.shape and gl.dtype == np.uint8
    assert _diff(gl, ref).max() <= TOL


@pytest.mark.gl
@pytest.mark.parametrize("scene", ["stack", "crossing", "random"])
def test_alpha_matches_reference_whatever_the_order(comp, scene):
    layers = {"stack": lambda: translucent_stack(5), "crossing": crossing_scene,
              "random": lambda: random_scene(2, CANVAS)}[scene]()
    gl = comp.render(layers, CANVAS, preview=True)
    ref = reference.reference_composite(layers, CANVAS)
    assert np.abs(gl[..., 3].astype(int) - ref[..., 3]).max() <= TOL
    assert np.any((ref[..., 3] > 0) & (ref[..., 3] < 255))  # the scene does have soft pixels


@pytest.mark.gl
@pytest.mark.parametrize("n", [3, 5])
def test_translucent_layers_that_do_not_cross_blend_in_depth_order(comp, n):
    # layers are blended farthest (mean depth) first: a stack whose depths do not cross
    # composites as the exact frame does, overlapped translucent pixels included
    layers = translucent_stack(n)
    gl = comp.render(layers, CANVAS, background=(250, 250, 240, 255), preview=True)
    ref = reference.reference_composite(layers, CANVAS, background=(250, 250, 240, 255))
    cover = sum((reference.reference_composite([L], CANVAS)[..., 3] > 0).astype(int) for L in layers)
    assert cover.max() >= 2
    assert _diff(gl, ref).max() <= TOL


@pytest.mark.gl
def test_exact_frames_unchanged_around_preview_frames(comp):
    layers = translucent_stack(5)
    exact = comp.render(layers, CANVAS, background=(0, 0, 0, 0))
    comp.render(layers, CANVAS, background=(0, 0, 0, 0), preview=True)
    comp.render(layers, CANVAS, size=(32, 24), preview=True, wireframe=True)
    assert np.array_equal(comp.render(layers, CANVAS, background=(0, 0, 0, 0)), exact)


@pytest.mark.gl
def test_draw_preview_into_a_texture_equals_render_preview(comp):
    layers = disc_over((40, 90, 220), (250, 150, 20), transparent=(0, 0, 0))
    bg = (255, 255, 255, 255)
    with comp.ctx:
        tex = comp.ctx.texture((48, 40), 4)
        comp.draw(layers, (48, 40), target=tex, background=bg, preview=True)
        drawn = np.frombuffer(tex.read(), np.uint8).reshape(40, 48, 4)
        tex.release()
    assert comp.last_method == "blend"
    assert np.array_equal(drawn, comp.render(layers, (48, 40), background=bg, preview=True))


@pytest.mark.gl
@pytest.mark.parametrize("seed", [0, 13])
def test_straight_alpha_on_the_cpu_equals_the_straight_pass(comp, seed):
    # the preview makes its soft pixels straight on the CPU; the exact frames' shader does
    # it on the GPU: the same rounding, checked on the premultiplied frame of a preview
    layers = random_scene(seed, CANVAS)
    with comp.ctx:
        tex = comp.ctx.texture(CANVAS, 4)
        comp.draw(layers, CANVAS, target=tex, background=(0, 0, 0, 0), preview=True)
        pre = np.frombuffer(tex.read(), np.uint8).reshape(CANVAS[1], CANVAS[0], 4).copy()
        tex.release()
    got = comp.render(layers, CANVAS, background=(0, 0, 0, 0), preview=True)
    a = pre[..., 3:].astype(np.float64)
    want = np.where(a > 0, np.minimum(np.floor(pre[..., :3] * 255.0 / np.maximum(a, 1) + 0.5), 255), 0)
    assert np.any((a > 0) & (a < 255))
    assert np.array_equal(got[..., 3], pre[..., 3])
    assert np.abs(got[..., :3].astype(int) - want).max() <= 1


def test_unpremultiply_soft_by_hand():
    frame = np.array([[[10, 20, 30, 40], [0, 0, 0, 0], [200, 100, 0, 255], [3, 0, 1, 1], [50, 60, 70, 60]]],
                     np.uint8)
    out = unpremultiply_soft(frame.copy())
    # 10*255/40 = 63.75 -> 64, 20 -> 127.5 -> 128 (half to even gives 128), 30 -> 191.25 -> 191;
    # alpha 0 and 255 untouched; 3*255/1 capped at 255; 70*255/60 = 297.5 capped
    assert out.tolist() == [[[64, 128, 191, 40], [0, 0, 0, 0], [200, 100, 0, 255], [255, 0, 255, 1],
                             [212, 255, 255, 60]]]
