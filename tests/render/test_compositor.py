"""GL compositor against the CPU reference (tests/render/reference.py) on small scenes,
with both edge methods (K-buffer and A-buffer), and the tie rule."""
from __future__ import annotations

import numpy as np
import pytest

moderngl = pytest.importorskip("moderngl")

from puppet.render import layers as layer_consts  # noqa: E402
from puppet.render.compositor import Compositor, DrawLayer, mesh_edges  # noqa: E402
from tests.render import reference  # noqa: E402
from tests.render.scenes import (CANVAS, crossing_scene, disc_image, disc_over,  # noqa: E402
                                 distance_to_segments, folded_strip, grid_mesh, image_layer,
                                 random_scene, rect_image, rotate, translucent_stack)

TOL = 2  # grey levels allowed between GL and the CPU reference (premultiplied)
MAX_DIFFS: list[float] = []  # every comparison's max difference, printed by the fixture


def premultiplied_levels(image):
    """Straight RGBA uint8 -> premultiplied RGBA in 0..255 (float)."""
    a = image.astype(np.float64)
    return np.concatenate([a[..., :3] * a[..., 3:] / 255.0, a[..., 3:]], axis=-1)


def assert_matches(gl, ref, tol=TOL):
    """Max abs difference of the premultiplied colours (grey levels) is within tol.

    Compared premultiplied: at alpha ~1/255 straight RGB is ill-conditioned (a
    rounding step of the premultiplied texel is a jump of up to 255 straight levels), and
    such a pixel contributes only alpha * RGB to anything composited over. Where alpha is
    255 the two measures are the same.
    """
    assert gl.shape == ref.shape and gl.dtype == np.uint8
    diff = np.abs(premultiplied_levels(gl) - premultiplied_levels(ref))
    where = np.unravel_index(diff.argmax(), diff.shape)
    assert diff.max() <= tol, (f"max diff {diff.max():.2f} at {where}: "
                               f"{gl[where[:2]]} vs {ref[where[:2]]}")
    MAX_DIFFS.append(float(diff.max()))
    return float(diff.max())


@pytest.fixture(scope="module", params=["kbuffer", "abuffer"])
def comp(request):
    c = Compositor(method=request.param)
    yield c
    c.release()
    if MAX_DIFFS:
        print(f"\nGL vs CPU reference: {len(MAX_DIFFS)} comparisons, max premultiplied "
              f"difference {max(MAX_DIFFS):.2f} grey levels")


def render_and_compare(comp, layers, canvas=CANVAS, **kw):
    gl = comp.render(layers, canvas, **kw)
    assert_matches(gl, reference.reference_composite(layers, canvas, **kw))
    return gl


def test_reference_constants_match_the_compositor():
    assert reference.ALPHA_MIN == layer_consts.ALPHA_MIN
    assert reference.ALPHA_OPAQUE == layer_consts.ALPHA_OPAQUE


@pytest.mark.gl
def test_crossing_strips_match_reference(comp):
    gl = render_and_compare(comp, crossing_scene())
    assert comp.last_method == comp.method and comp.last_overflow == 0
    red_centres = rotate(np.array([[14.5, 24.0], [46.0, 24.0]]), 4, (32, 24))
    (x0, y0), (x1, y1) = np.floor(red_centres).astype(int)
    assert tuple(gl[y0, x0]) == (220, 30, 30, 255)  # red in front of the left bar
    assert tuple(gl[y1, x1]) == (30, 40, 210, 255)  # blue in front of the right bar


@pytest.mark.gl
def test_list_order_does_not_matter_without_ties(comp):
    layers = crossing_scene()
    a = comp.render(layers, CANVAS)
    b = comp.render(layers[::-1], CANVAS)
    assert np.abs(a.astype(int) - b.astype(int)).max() <= 1


@pytest.mark.gl
def test_soft_edge_has_no_dark_fringe(comp):
    # White disc whose transparent texels are black, over a white layer: every pixel,
    # edges included, must stay white (a fringe would come from unpremultiplied
    # filtering or from an edge fragment occluding the layer behind).
    layers = disc_over((255, 255, 255), (255, 255, 255), transparent=(0, 0, 0))
    gl = render_and_compare(comp, layers, (48, 40), background=(0, 0, 0, 255))
    assert gl[..., :3].min() >= 254
    layers = disc_over((40, 90, 220), (250, 150, 20), transparent=(0, 0, 0))
    for bg in [(0, 0, 0, 0), (255, 255, 255, 255)]:
        render_and_compare(comp, layers, (48, 40), background=bg)


@pytest.mark.gl
def test_translucent_stack_matches_reference(comp):
    render_and_compare(comp, translucent_stack(3), background=(250, 250, 240, 255))


@pytest.mark.gl
@pytest.mark.parametrize("slope", [0.15, -0.15])
def test_layer_folded_over_itself(comp, slope):
    layer = folded_strip(slope)
    gl = render_and_compare(comp, [layer])
    # canvas (10.5, 25.5) is covered by rest x ~ 10 (left half, red) and, folded, by
    # rest x ~ 54 (right half, green): the higher depth must win.
    r, g = int(gl[25, 10, 0]), int(gl[25, 10, 1])
    assert (g > 180 and r < 60) if slope > 0 else (r > 180 and g < 60)


def _half(layer: DrawLayer, right: bool) -> DrawLayer:
    """The same layer with only the triangles of one side of the fold."""
    x = layer.rest[layer.triangles].mean(axis=1)[:, 0]
    tri = layer.triangles[(x > 32) == right]
    return DrawLayer(f"{layer.key}-{int(right)}", layer.image, layer.offset, layer.rest,
                     layer.deformed, tri, layer.depth)


@pytest.mark.gl
@pytest.mark.parametrize("background", [(0, 0, 0, 0), (255, 255, 255, 255)])
def test_self_overlap_at_equal_depth_shows_no_background(comp, background):
    # The strip folded at one depth: its halves overlap at exactly equal depth, and the
    # soft edge of each lies over the opaque inside of the other. Wherever either half
    # alone is opaque, the folded layer must be opaque too (no seam of background).
    layer = folded_strip(0.0)
    gl = render_and_compare(comp, [layer], background=background)
    alone = [comp.render([_half(layer, side)], CANVAS) for side in (False, True)]
    covered = (alone[0][..., 3] == 255) | (alone[1][..., 3] == 255)
    assert covered.sum() > 150
    if background[3] == 0:
        assert gl[covered, 3].min() == 255
    else:
        assert gl[covered, :3].astype(int).sum(-1).max() < 600  # no white seam


@pytest.mark.gl
def test_equal_depth_between_layers_later_layer_wins(comp):
    red = image_layer("red", rect_image(30, 20, (1.5, 1.5, 28.5, 18.5), (230, 20, 20)),
                      (10, 10), nx=3, ny=2, depth=2.0)
    blue = image_layer("blue", rect_image(30, 20, (1.5, 1.5, 28.5, 18.5), (20, 20, 230)),
                       (22, 18), nx=3, ny=2, depth=2.0,
                       deform=lambda P: rotate(P, 7, (37, 28)))
    a = render_and_compare(comp, [red, blue])
    b = render_and_compare(comp, [blue, red])
    assert tuple(a[26, 30]) == (20, 20, 230, 255)  # overlap: the later (blue) wins
    assert tuple(b[26, 30]) == (230, 20, 20, 255)


@pytest.mark.gl
def test_translucent_ties_in_one_layer_composite_in_triangle_order(comp):
    # Two quads of one layer on top of each other at one depth, sampling a red and a
    # blue half-transparent part of the texture: both show, the later one over.
    img = np.zeros((10, 20, 4), np.uint8)
    img[:, :10] = (255, 0, 0, 128)
    img[:, 10:] = (0, 0, 255, 128)
    v, f = grid_mesh(0, 0, 1, 1, 1, 1)
    rest = np.concatenate([v * (8, 8) + (1, 1), v * (8, 8) + (11, 1)])  # texel space
    quad = v * (30, 20) + (15, 12)
    layer = DrawLayer("pair", img, (0, 0), rest, np.concatenate([quad, quad]),
                      np.concatenate([f, f + 4]), np.full(8, 1.0))
    gl = render_and_compare(comp, [layer], background=(255, 255, 255, 255))
    r, g, b, _ = gl[22, 30].astype(int)
    assert b > r + 50 and g < 140  # blue (later triangles) over red over white
    flipped = DrawLayer("pair2", img, (0, 0), rest, layer.deformed,
                        np.concatenate([f + 4, f]), layer.depth)
    r2, _, b2, _ = comp.render([flipped], CANVAS, background=(255, 255, 255, 255))[22, 30]
    assert int(r2) > int(b2) + 50


@pytest.mark.gl
def test_background_colour_and_image(comp):
    layer = image_layer("disc", disc_image(30, 11, (250, 150, 20)), (17, 9), nx=3, ny=3,
                        deform=lambda P: rotate(P, 20, (32, 24)), depth=0.5)
    ys, xs = np.mgrid[0:48, 0:64]
    rng = np.random.default_rng(1)
    big = np.stack([xs * 4, ys * 5, rng.integers(0, 256, xs.shape), 128 + xs * 2], -1)
    small = rng.integers(0, 256, (12, 16, 4))
    small[..., 3] = np.maximum(small[..., 3], 40)
    opaque = small.copy()
    opaque[..., 3] = 255
    for bg in [(30, 60, 90, 255), (30, 60, 90, 128), big.astype(np.uint8),
               small.astype(np.uint8), opaque.astype(np.uint8)]:
        gl = render_and_compare(comp, [layer], background=bg)
        if isinstance(bg, tuple):
            assert np.abs(gl[0, 0].astype(int) - bg).max() <= 1


@pytest.mark.gl
@pytest.mark.parametrize("size", [(128, 96), (32, 24), (80, 30)])
def test_output_size_scales_the_canvas(comp, size):
    gl = render_and_compare(comp, crossing_scene(), size=size, background=(255, 255, 255, 255))
    assert gl.shape == (size[1], size[0], 4)


@pytest.mark.gl
@pytest.mark.parametrize("seed", [0, 2, 13])
def test_random_scenes_match_reference(comp, seed):
    canvas, bg = (96, 72), [(0, 0, 0, 0), (255, 255, 255, 255)][seed % 2]
    render_and_compare(comp, random_scene(seed, canvas), canvas, background=bg)


@pytest.mark.gl
def test_wireframe_changes_pixels_along_edges_only(comp):
    layers = crossing_scene()
    plain = comp.render(layers, CANVAS, background=(255, 255, 255, 255))
    wired = comp.render(layers, CANVAS, background=(255, 255, 255, 255), wireframe=True)
    changed = np.any(plain != wired, axis=-1)
    assert changed.sum() > 300
    ys, xs = np.nonzero(changed)
    centres = np.stack([xs + 0.5, ys + 0.5], 1)
    A = np.concatenate([l.deformed[mesh_edges(l.triangles)[:, 0]] for l in layers])
    B = np.concatenate([l.deformed[mesh_edges(l.triangles)[:, 1]] for l in layers])
    assert distance_to_segments(centres, A, B).max() <= 1.0
    assert (wired[changed, :3].astype(int).sum(-1) < plain[changed, :3].astype(int).sum(-1)).all()


@pytest.mark.gl
@pytest.mark.parametrize("alpha_low, tol", [(255, 1), (128, 2)])
def test_identity_full_canvas_quad(comp, alpha_low, tol):
    rng = np.random.default_rng(7)
    img = rng.integers(0, 256, (48, 64, 4)).astype(np.uint8)
    img[..., 3] = rng.integers(alpha_low, 256, (48, 64))
    layer = image_layer("quad", img, (0, 0), nx=4, ny=3, depth=2.0)
    gl = comp.render([layer], CANVAS)
    assert np.abs(gl.astype(int) - img.astype(int)).max() <= tol


def test_premultiply_rounds_to_nearest_for_every_colour_and_alpha():
    from puppet.render.layers import premultiply
    c = np.arange(256, dtype=np.uint8)
    img = np.zeros((256, 256, 4), np.uint8)
    img[..., :3] = c[None, :, None]
    img[..., 3] = c[:, None]
    out = premultiply(img)
    ref = np.floor(img[..., :3].astype(np.float64) * img[..., 3:] / 255 + 0.5)
    np.testing.assert_array_equal(out[..., :3], ref)
    np.testing.assert_array_equal(out[..., 3], img[..., 3])
    mixed = np.random.default_rng(3).integers(0, 256, (37, 53, 4), dtype=np.uint8)  # channels differ, odd width
    ref = np.floor(mixed[..., :3].astype(np.float64) * mixed[..., 3:] / 255 + 0.5)
    np.testing.assert_array_equal(premultiply(mixed)[..., :3], ref)
    np.testing.assert_array_equal(premultiply(mixed[:, ::2])[..., :3], ref[:, ::2])  # a strided view
