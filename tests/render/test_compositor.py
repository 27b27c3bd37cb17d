"""GL compositor against a CPU reference (tests/render/reference.py) on small scenes."""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

moderngl = pytest.importorskip("moderngl")

from puppet.render.compositor import Compositor, DrawLayer, mesh_edges  # noqa: E402
from puppet.render.programs import (load_program, set_uniform, shader_dir,  # noqa: E402
                                    split_stages)

_spec = importlib.util.spec_from_file_location(
    "puppet_tests_render_reference", Path(__file__).with_name("reference.py"))
reference = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(reference)

TOL = 3  # grey levels allowed between GL and the CPU reference
CANVAS = (64, 48)
MAX_DIFFS: list[float] = []  # every comparison's max difference, printed by the fixture


# -- scene helpers -------------------------------------------------------------------
def rect_image(w, h, box, colour, *, transparent=(0, 0, 0)):
    """Image with an anti-aliased rectangle: exact area coverage of box (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = box
    xs, ys = np.arange(w), np.arange(h)
    cx = np.clip(np.minimum(xs + 1, x1) - np.maximum(xs, x0), 0, 1)
    cy = np.clip(np.minimum(ys + 1, y1) - np.maximum(ys, y0), 0, 1)
    img = np.zeros((h, w, 4), np.uint8)
    img[..., :3] = transparent
    alpha = np.rint(np.outer(cy, cx) * 255).astype(np.uint8)
    colour = np.broadcast_to(np.asarray(colour, np.uint8), (h, w, 3))
    img[alpha > 0, :3] = colour[alpha > 0]
    img[..., 3] = alpha
    return img


def disc_image(size, radius, colour, *, transparent=(0, 0, 0)):
    """Anti-aliased disc (8x8 supersampled coverage); transparent pixels get `transparent`."""
    sub = (np.arange(size * 8) + 0.5) / 8 - size / 2
    inside = (sub[None, :] ** 2 + sub[:, None] ** 2) <= radius ** 2
    alpha = inside.reshape(size, 8, size, 8).mean(axis=(1, 3))
    img = np.zeros((size, size, 4), np.uint8)
    img[..., :3] = transparent
    img[alpha > 0, :3] = colour
    img[..., 3] = np.rint(alpha * 255).astype(np.uint8)
    return img


def grid_mesh(x0, y0, x1, y1, nx, ny):
    """Vertices (n, 2) and triangles (m, 3) of an nx x ny cell grid over a rectangle."""
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    V = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    i = np.arange(ny)[:, None] * (nx + 1) + np.arange(nx)[None, :]
    a, b, c, d = i, i + 1, i + nx + 1, i + nx + 2
    F = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                        np.stack([a, d, c], -1).reshape(-1, 3)])
    return V, F


def rotate(P, degrees, centre):
    t = math.radians(degrees)
    R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    return (P - centre) @ R.T + centre


def image_layer(key, image, offset, *, nx=4, ny=4, deform=None, depth=0.0):
    """A layer whose mesh covers its whole image rectangle."""
    h, w = image.shape[:2]
    rest, tri = grid_mesh(offset[0], offset[1], offset[0] + w, offset[1] + h, nx, ny)
    deformed = rest.copy() if deform is None else deform(rest)
    d = depth(rest) if callable(depth) else np.full(len(rest), float(depth))
    return DrawLayer(key, image, offset, rest, deformed, tri, d)


def crossing_scene():
    """Red horizontal strip whose depth falls from 3 (left) to -1 (right) across two blue
    vertical bars at depth ~1: red is in front at the left bar, behind at the right."""
    red_img = rect_image(60, 14, (2.3, 2.4, 57.6, 11.7), (220, 30, 30))
    red = image_layer("red", red_img, (2, 17), nx=6, ny=2,
                      deform=lambda P: rotate(P, 4, (32, 24)),
                      depth=lambda P: 3 - 4 * (P[:, 0] - 2) / 60)
    blue_img = np.maximum(rect_image(52, 44, (3.3, 2.2, 13.6, 41.7), (30, 40, 210)),
                          rect_image(52, 44, (35.4, 2.2, 45.7, 41.7), (30, 40, 210)))
    v1, f1 = grid_mesh(7, 2, 22, 46, 2, 4)
    v2, f2 = grid_mesh(38, 2, 54, 46, 2, 4)
    rest = np.concatenate([v1, v2])
    blue = DrawLayer("blue", blue_img, (6, 2), rest, rotate(rest, -3, (32, 24)),
                     np.concatenate([f1, f2 + len(v1)]), 1 + 0.1 * (rest[:, 1] - 24) / 24)
    return [red, blue]


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


@pytest.fixture(scope="module")
def comp():
    c = Compositor()
    yield c
    c.release()
    if MAX_DIFFS:
        print(f"\nGL vs CPU reference: {len(MAX_DIFFS)} comparisons, max premultiplied "
              f"difference {max(MAX_DIFFS):.2f} grey levels")


# -- tests ---------------------------------------------------------------------------
@pytest.mark.gl
def test_crossing_strips_match_reference(comp):
    layers = crossing_scene()
    gl = comp.render(layers, CANVAS)
    assert_matches(gl, reference.reference_composite(layers, CANVAS))
    assert comp.last_peels == 2
    red_centres = rotate(np.array([[14.5, 24.0], [46.0, 24.0]]), 4, (32, 24))
    (x0, y0), (x1, y1) = np.floor(red_centres).astype(int)
    assert tuple(gl[y0, x0]) == (220, 30, 30, 255)  # red in front of the left bar
    assert tuple(gl[y1, x1]) == (30, 40, 210, 255)  # blue in front of the right bar


@pytest.mark.gl
def test_list_order_does_not_matter(comp):
    layers = crossing_scene()
    a = comp.render(layers, CANVAS)
    b = comp.render(layers[::-1], CANVAS)
    assert np.abs(a.astype(int) - b.astype(int)).max() <= 1


def _disc_over(back_colour, front_colour, transparent):
    back = image_layer("back", rect_image(48, 40, (0, 0, 48, 40), back_colour), (0, 0),
                       nx=2, ny=2, depth=0.0)
    front = image_layer("front", disc_image(30, 11, front_colour, transparent=transparent),
                        (9, 5), nx=5, ny=5, depth=1.0,
                        deform=lambda P: rotate(P, 10, (24, 20)) + (0.3, 0.2))
    return [front, back]  # the front layer drawn first: the halo-prone order


@pytest.mark.gl
def test_soft_edge_has_no_dark_fringe(comp):
    # White disc whose transparent texels are black, over a white layer: every pixel,
    # edges included, must stay white (a fringe would come from unpremultiplied
    # filtering or from an edge fragment occluding the layer behind).
    layers = _disc_over((255, 255, 255), (255, 255, 255), transparent=(0, 0, 0))
    gl = comp.render(layers, (48, 40), background=(0, 0, 0, 255))
    assert gl[..., :3].min() >= 254
    assert_matches(gl, reference.reference_composite(layers, (48, 40),
                                                     background=(0, 0, 0, 255)))
    layers = _disc_over((40, 90, 220), (250, 150, 20), transparent=(0, 0, 0))
    for bg in [(0, 0, 0, 0), (255, 255, 255, 255)]:
        assert_matches(comp.render(layers, (48, 40), background=bg),
                       reference.reference_composite(layers, (48, 40), background=bg))


@pytest.mark.gl
def test_translucent_stack_matches_reference(comp):
    img = rect_image(40, 30, (2.5, 2.5, 37.5, 27.5), (255, 255, 255))
    layers = []
    for i, (colour, alpha) in enumerate([((255, 0, 0), 150), ((0, 200, 0), 100),
                                         ((0, 0, 255), 200)]):
        im = img.copy()
        im[..., :3] = colour
        im[..., 3] = (im[..., 3].astype(int) * alpha // 255).astype(np.uint8)
        layers.append(image_layer(f"t{i}", im, (4 + 8 * i, 3 + 6 * i), nx=3, ny=2,
                                  depth=lambda P, i=i: (i * 7 % 3) + 0.01 * P[:, 0]))
    gl = comp.render(layers, CANVAS, background=(250, 250, 240, 255))
    assert comp.last_peels == 3
    assert_matches(gl, reference.reference_composite(layers, CANVAS,
                                                     background=(250, 250, 240, 255)))


def _folded_strip(sign):
    """Red-to-green strip folded at x = 32: its right half lies over its left half."""
    img = rect_image(60, 12, (2.4, 2.3, 57.6, 9.7), (0, 0, 0))
    img[..., 0] = np.where(img[..., 3] > 0, np.linspace(255, 0, 60)[None, :], 0)
    img[..., 1] = np.where(img[..., 3] > 0, np.linspace(0, 255, 60)[None, :], 0)
    rest, tri = grid_mesh(2, 18, 62, 30, 15, 2)
    x = rest[:, 0]
    deformed = np.stack([np.where(x > 32, 64 - x, x), rest[:, 1] + 0.15 * np.maximum(x - 32, 0)], 1)
    return DrawLayer("fold", img, (2, 18), rest, deformed, tri, sign * 0.15 * (x - 32))


@pytest.mark.gl
@pytest.mark.parametrize("sign", [1, -1])
def test_layer_folded_over_itself(comp, sign):
    layer = _folded_strip(sign)
    gl = comp.render([layer], CANVAS)
    assert_matches(gl, reference.reference_composite([layer], CANVAS))
    # canvas (10.5, 25.5) is covered by rest x ~ 10 (left half, red) and, folded, by
    # rest x ~ 54 (right half, green): the higher depth must win.
    r, g = int(gl[25, 10, 0]), int(gl[25, 10, 1])
    assert (g > 180 and r < 60) if sign > 0 else (r > 180 and g < 60)


@pytest.mark.gl
def test_background_colour_and_image(comp):
    layer = image_layer("disc", disc_image(30, 11, (250, 150, 20)), (17, 9), nx=3, ny=3,
                        deform=lambda P: rotate(P, 20, (32, 24)), depth=0.5)
    ys, xs = np.mgrid[0:48, 0:64]
    rng = np.random.default_rng(1)
    big = np.stack([xs * 4, ys * 5, rng.integers(0, 256, xs.shape), 128 + xs * 2], -1)
    small = rng.integers(0, 256, (12, 16, 4))
    small[..., 3] = np.maximum(small[..., 3], 40)
    for bg in [(30, 60, 90, 255), (30, 60, 90, 128), big.astype(np.uint8),
               small.astype(np.uint8)]:
        gl = comp.render([layer], CANVAS, background=bg)
        assert_matches(gl, reference.reference_composite([layer], CANVAS, background=bg))
        if isinstance(bg, tuple):
            assert np.abs(gl[0, 0].astype(int) - bg).max() <= 1


@pytest.mark.gl
@pytest.mark.parametrize("size", [(128, 96), (32, 24), (80, 30)])
def test_output_size_scales_the_canvas(comp, size):
    layers = crossing_scene()
    gl = comp.render(layers, CANVAS, size=size, background=(255, 255, 255, 255))
    assert gl.shape == (size[1], size[0], 4)
    assert_matches(gl, reference.reference_composite(layers, CANVAS, size=size,
                                                     background=(255, 255, 255, 255)))


def random_scene(seed, canvas):
    """2-5 translucent soft discs, bent and rotated, with wavy depths that cross."""
    rng = np.random.default_rng(seed)
    layers = []
    for i in range(int(rng.integers(2, 6))):
        w = int(rng.integers(20, 60))
        img = disc_image(w, w / 2 - 3, tuple(int(v) for v in rng.integers(0, 256, 3)))
        img[..., 3] = np.rint(img[..., 3] * rng.uniform(0.4, 1.0)).astype(np.uint8)
        off = (float(rng.uniform(-5, canvas[0] - w + 5)), float(rng.uniform(-5, canvas[1] - w + 5)))
        angle, bend = rng.uniform(-40, 40), rng.uniform(-0.3, 0.3)
        amp, phase = rng.uniform(0, 3), rng.uniform(0, 6)

        def deform(P, angle=angle, bend=bend, centre=np.add(off, w / 2), w=w):
            Q = rotate(P, angle, centre)
            Q[:, 1] += bend * (Q[:, 0] - centre[0]) ** 2 / w
            return Q
        def depth(P, i=i, a=amp, p=phase):
            return i + a * np.sin(P[:, 0] / 15 + p)
        layers.append(image_layer(f"r{i}", img, off, nx=int(rng.integers(2, 8)),
                                  ny=int(rng.integers(2, 8)), deform=deform, depth=depth))
    return layers


@pytest.mark.gl
@pytest.mark.parametrize("seed", [0, 2, 13])
def test_random_scenes_match_reference(comp, seed):
    canvas, bg = (96, 72), [(0, 0, 0, 0), (255, 255, 255, 255)][seed % 2]
    layers = random_scene(seed, canvas)
    gl = comp.render(layers, canvas, background=bg)
    assert comp.last_peels >= 2
    assert_matches(gl, reference.reference_composite(layers, canvas, background=bg))


def _distance_to_segments(P, A, B):
    d = B - A
    t = np.clip(((P[:, None] - A[None]) * d[None]).sum(-1) / (d * d).sum(-1)[None], 0, 1)
    closest = A[None] + t[..., None] * d[None]
    return np.linalg.norm(P[:, None] - closest, axis=-1).min(axis=1)


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
    assert _distance_to_segments(centres, A, B).max() <= 1.0
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


@pytest.mark.gl
def test_textures_and_index_buffers_are_cached(comp):
    layers = crossing_scene()
    comp.render(layers, CANVAS)
    tex, ibo = comp._textures["red"][1], comp._meshes["red"].ibo
    layers[0].deformed = layers[0].deformed + 1.0
    layers[0].depth = layers[0].depth * 0.5
    comp.render(layers, CANVAS)
    assert comp._textures["red"][1] is tex and comp._meshes["red"].ibo is ibo
    layers[0].image = layers[0].image.copy()
    comp.render(layers, CANVAS)
    assert comp._textures["red"][1] is not tex


@pytest.mark.gl
def test_bad_input_is_rejected(comp):
    layers = crossing_scene()
    with pytest.raises(ValueError):
        comp.render([layers[0], layers[0]], CANVAS)
    layers[0].image = layers[0].image[..., :3]
    with pytest.raises(ValueError):
        comp.render(layers, CANVAS)
    assert comp.render([], CANVAS, background=(1, 2, 3, 255))[5, 5].tolist() == [1, 2, 3, 255]


@pytest.mark.gl
def test_programs_compile_and_are_cached(comp):
    names = sorted(p.name[:-5] for p in shader_dir().iterdir() if p.name.endswith(".glsl"))
    assert {"peel", "under", "resolve", "wire"} <= set(names)
    for name in names:
        assert load_program(comp.ctx, name) is load_program(comp.ctx, name)
    assert not set_uniform(load_program(comp.ctx, "under"), "u_no_such_uniform", 1.0)


def test_split_stages_inserts_defines_after_version():
    stages = split_stages("#version 330 core\n#if defined VERTEX_SHADER\nv\n"
                          "#elif defined FRAGMENT_SHADER\nf\n#endif\n")
    assert set(stages) == {"vertex_shader", "fragment_shader"}
    assert stages["vertex_shader"].splitlines()[:3] == [
        "#version 330 core", "#define VERTEX_SHADER", "#line 2"]
    with pytest.raises(ValueError):
        split_stages("void main() {}\n")
