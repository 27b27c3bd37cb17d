"""Compositor API: drawing into a given texture or framebuffer without read-back, cheap
vertex updates of uploaded layers, the K-buffer's fallback, caching, programs."""
from __future__ import annotations

import numpy as np
import pytest

moderngl = pytest.importorskip("moderngl")

from puppet.render.compositor import K, Compositor, DrawLayer  # noqa: E402
from puppet.render.layers import ALPHA_MIN, ALPHA_OPAQUE, classify_triangles  # noqa: E402
from puppet.render.programs import (glsl_literal, load_program, set_uniform,  # noqa: E402
                                    shader_dir, shader_source, split_stages)
from tests.render import reference  # noqa: E402
from tests.render.scenes import (CANVAS, crossing_scene, grid_mesh, rect_image, rotate,  # noqa: E402
                                 translucent_stack)
from tests.render.test_compositor import assert_matches  # noqa: E402

WHITE = (255, 255, 255, 255)


@pytest.fixture(scope="module")
def comp():
    c = Compositor()
    yield c
    c.release()


def straight(premultiplied: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA uint8 -> straight RGBA uint8."""
    p = premultiplied.astype(np.float64)
    a = p[..., 3:]
    rgb = np.where(a > 0, np.minimum(p[..., :3] * 255 / np.maximum(a, 1), 255), 0)
    return np.concatenate([np.rint(rgb), a], axis=-1).astype(np.uint8)


def read_texture(tex) -> np.ndarray:
    w, h = tex.size
    return np.frombuffer(tex.read(), np.uint8).reshape(h, w, 4)


@pytest.mark.gl
@pytest.mark.parametrize("background", [WHITE, (0, 0, 0, 0)])
def test_draw_into_a_texture_then_read_it(comp, background):
    layers = crossing_scene()
    with comp.ctx:
        tex = comp.ctx.texture((80, 60), 4)
        comp.draw(layers, CANVAS, target=tex, background=background)
        got = read_texture(tex)
        comp.draw(layers, CANVAS, target=tex, background=background, flip_y=True)
        flipped = read_texture(tex)
        tex.release()
    want = comp.render(layers, CANVAS, size=(80, 60), background=background)
    if background[3] == 255:
        assert np.abs(got.astype(int) - want).max() <= 1
    else:  # draw() leaves premultiplied RGBA
        assert_matches(straight(got), want, tol=2)
        assert (got[..., :3] <= got[..., 3:]).all() and (got[..., 3] < 255).any()
    assert np.array_equal(flipped, got[::-1])


@pytest.mark.gl
def test_draw_into_a_framebuffer_restores_the_caller_binding(comp):
    layers = crossing_scene()
    with comp.ctx:
        ctx = comp.ctx
        rb = ctx.renderbuffer((64, 48), 4)
        fbo = ctx.framebuffer([rb])
        other = ctx.framebuffer([ctx.renderbuffer((8, 8), 4)])
        other.use()
        comp.draw(layers, CANVAS, target=fbo, background=WHITE)
        assert ctx.fbo is other
        got = np.frombuffer(fbo.read(components=4), np.uint8).reshape(48, 64, 4)
        fbo.release()
        rb.release()
    want = comp.render(layers, CANVAS, background=WHITE)
    assert np.abs(got.astype(int) - want).max() <= 1


@pytest.mark.gl
def test_update_writes_vertices_without_recreating_buffers(comp):
    layers = crossing_scene()
    for layer in layers:
        comp.upload(layer)
    mesh = comp._meshes["red"]
    vbo, vaos, tex = mesh.vbo, dict(mesh.vaos), comp._textures["red"][1]
    moved = layers[0].deformed + (1.5, -2.0)
    deeper = layers[0].depth - 3.0  # now behind both bars
    comp.update("red", deformed=moved, depth=deeper)
    got = comp.render(["red", "blue"], CANVAS, background=WHITE)
    assert comp._meshes["red"] is mesh and mesh.vbo is vbo and mesh.vaos == vaos
    assert comp._textures["red"][1] is tex
    changed = DrawLayer("red2", layers[0].image, layers[0].offset, layers[0].rest, moved,
                        layers[0].triangles, deeper)
    want = reference.reference_composite([changed, layers[1]], CANVAS, background=WHITE)
    assert_matches(got, want)
    comp.update("red", depth=layers[0].depth)  # positions kept, depth back
    again = comp.render(["red", "blue"], CANVAS, background=WHITE)
    assert not np.array_equal(again, got)
    with pytest.raises(KeyError):
        comp.update("nobody", depth=deeper)
    with pytest.raises(ValueError):
        comp.update("red", deformed=moved[:-1])
    with pytest.raises(KeyError):
        comp.render(["red", "nobody"], CANVAS)


@pytest.mark.gl
def test_textures_and_index_buffers_are_cached(comp):
    layers = crossing_scene()
    comp.render(layers, CANVAS)
    tex, mesh = comp._textures["red"][1], comp._meshes["red"]
    layers[0].deformed = layers[0].deformed + 1.0
    layers[0].depth = layers[0].depth * 0.5
    comp.render(layers, CANVAS)
    assert comp._textures["red"][1] is tex and comp._meshes["red"] is mesh
    layers[0].image = layers[0].image.copy()
    comp.render(layers, CANVAS)
    assert comp._textures["red"][1] is not tex and comp._meshes["red"] is not mesh


@pytest.mark.gl
def test_retain_forgets_the_layers_not_named():
    c = Compositor()
    try:
        layers = crossing_scene()
        keys = [layer.key for layer in layers]
        background = np.zeros((60, 80, 4), np.uint8)
        c.render(layers, CANVAS, background=background)  # a background image: cached too, never forgotten
        assert set(c._textures) == set(keys) | {"\0background"} and set(c._meshes) == set(keys)
        assert c.retain(keys) == 0
        assert c.retain(keys[:1]) == len(keys) - 1
        assert set(c._textures) == {keys[0], "\0background"} and set(c._meshes) == {keys[0]}
        with pytest.raises(KeyError):
            c.render(keys[1:], CANVAS)
        want = c.render(layers, CANVAS)  # uploaded again
        assert set(c._meshes) == set(keys) and want.shape == (48, 64, 4)
    finally:
        c.release()


@pytest.mark.gl
def test_more_translucent_fragments_than_k_fall_back_to_the_abuffer(comp):
    layers = translucent_stack(K + 2)
    want = reference.reference_composite(layers, CANVAS, background=WHITE)
    assert_matches(comp.render(layers, CANVAS, background=WHITE), want)
    assert comp.last_method == "abuffer" and comp.last_overflow > 0
    with comp.ctx:
        overflow, used, lost = comp._passes.read_counters()  # the A-buffer's frame
    assert used > 0 and lost == 0 and used <= comp._passes.nodes.size // 16
    # the next previews use the A-buffer, and return to the K-buffer when it suffices
    with comp.ctx:
        tex = comp.ctx.texture(CANVAS, 4)
        comp.draw(layers, CANVAS, target=tex, background=WHITE)
        assert comp.last_method == "abuffer"
        assert_matches(read_texture(tex), want)
        comp.draw(crossing_scene(), CANVAS, target=tex, background=WHITE)
        comp.draw(crossing_scene(), CANVAS, target=tex, background=WHITE)
        assert comp.last_method == "kbuffer"
        tex.release()


@pytest.mark.gl
def test_no_memory_for_the_kbuffer_falls_back_to_the_abuffer(monkeypatch):
    from puppet.render.gpu import FrameTargets

    def no_memory(self):
        raise moderngl.Error("out of memory")
    monkeypatch.setattr(FrameTargets, "kbuffer", no_memory)
    layers = crossing_scene()
    c = Compositor(method="kbuffer")
    try:
        got = c.render(layers, CANVAS, background=WHITE)
        assert c.last_method == "abuffer"
    finally:
        c.release()
    assert_matches(got, reference.reference_composite(layers, CANVAS, background=WHITE))


@pytest.mark.gl
def test_forced_kbuffer_preview_merges_beyond_k(comp):
    # a draw() cannot redraw: beyond K it merges the two farthest entries, exact when the
    # fragments arrive in depth order (layers whose depths do not cross), and the
    # overflow is counted when the next frame starts
    layers = translucent_stack(K + 2)
    want = reference.reference_composite(layers, CANVAS, background=WHITE)
    with comp.ctx:
        kb = Compositor(comp.ctx, method="kbuffer")
        tex = comp.ctx.texture(CANVAS, 4)
        kb.draw(layers, CANVAS, target=tex, background=WHITE)
        assert_matches(read_texture(tex), want)
        kb.draw(crossing_scene(), CANVAS, target=tex, background=WHITE)
        assert kb.last_overflow > 0 and kb.last_method == "kbuffer"
        tex.release()
        kb.release()


@pytest.mark.gl
def test_bad_input_is_rejected(comp):
    layers = crossing_scene()
    with pytest.raises(ValueError):
        comp.render([layers[0], layers[0]], CANVAS)
    layers[0].image = layers[0].image[..., :3]
    with pytest.raises(ValueError):
        comp.render(layers, CANVAS)
    assert comp.render([], CANVAS, background=(1, 2, 3, 255))[5, 5].tolist() == [1, 2, 3, 255]
    with pytest.raises(ValueError):
        Compositor(comp.ctx, method="peel")
    with comp.ctx, pytest.raises(ValueError):
        comp.draw([], CANVAS, target=comp.ctx.texture((4, 4), 3))


def test_triangle_classes():
    img = rect_image(30, 10, (0, 0, 15, 10), (255, 0, 0))  # opaque x < 15, clear after
    img[5, 3, 3] = 200  # one translucent texel
    v, f = grid_mesh(0, 0, 30, 10, 6, 2)  # cells 5 texels wide
    edge, empty = classify_triangles(img, v / (30, 10), f)
    x0 = v[f][:, :, 0].min(axis=1)
    assert empty[x0 >= 20].all() and not empty[x0 < 20].any()
    assert not edge[(x0 >= 5) & (x0 < 10)].any()  # reach: columns 4..10, all opaque
    assert edge[x0 < 5].all()  # the translucent texel is in reach of both rows
    assert edge[(x0 >= 10) & (x0 < 20)].all()  # reach the border at column 15
    assert not edge[empty].any()


@pytest.mark.gl
def test_programs_compile_and_are_cached(comp):
    names = sorted(p.name[:-5] for p in shader_dir().iterdir() if p.name.endswith(".glsl"))
    assert {"layer", "background", "straight", "wire"} <= set(names)
    for name in ("background", "straight", "wire"):
        assert load_program(comp.ctx, name) is load_program(comp.ctx, name)
    assert not set_uniform(load_program(comp.ctx, "straight"), "u_no_such_uniform", 1.0)


def test_alpha_constants_are_injected_not_repeated():
    stages = split_stages(shader_source("layer"), "layer",
                          defines={"ALPHA_MIN": ALPHA_MIN, "OPAQUE_PASS": 1})
    assert f"#define ALPHA_MIN {glsl_literal(ALPHA_MIN)}" in stages["fragment_shader"]
    assert float(glsl_literal(ALPHA_MIN)) == ALPHA_MIN
    assert glsl_literal(1.0) == "1.0" and glsl_literal(True) == "1" and glsl_literal(3) == "3"
    body = shader_source("layer")
    assert str(ALPHA_MIN)[:6] not in body and "254.5" not in body and str(ALPHA_OPAQUE)[:6] not in body


def test_split_stages_inserts_defines_after_version():
    stages = split_stages("#version 330 core\n#if defined VERTEX_SHADER\nv\n"
                          "#elif defined FRAGMENT_SHADER\nf\n#endif\n")
    assert set(stages) == {"vertex_shader", "fragment_shader"}
    assert stages["vertex_shader"].splitlines()[:3] == [
        "#version 330 core", "#define VERTEX_SHADER", "#line 2"]
    with pytest.raises(ValueError):
        split_stages("void main() {}\n")


@pytest.mark.gl
def test_a_layer_drawn_from_its_box_looks_as_drawn_from_its_whole_image(comp):
    """LayerImage.drawn (the box of nonzero alpha with a transparent border) gives the
    same frame as the whole image: clamped sampling reads the same zeros beyond the box."""
    from puppet.scene.rig.build import LayerImage
    from tests.render.scenes import disc_image

    whole = np.zeros((48, 64, 4), np.uint8)
    whole[9:39, 20:50] = disc_image(30, 11, (40, 160, 220))
    im = LayerImage(rgba=whole, offset=(0.5, -1.0), mask=whole[..., 3] > 0, from_source=False)
    box, offset = im.drawn
    assert im.drawn[0] is box  # cached: the compositor keeps the texture
    # the disc covers columns 24-45 and rows 13-34 of the whole image: one pixel more a side
    assert box.shape == (24, 24, 4) and offset == (0.5 + 23, -1.0 + 12)
    assert (box[0, :, 3] == 0).all() and (box[-1, :, 3] == 0).all() and (box[:, 0, 3] == 0).all()
    assert whole[..., 3].sum() == box[..., 3].astype(int).sum()
    rest, tri = grid_mesh(0.5, -1.0, 64.5, 47.0, 8, 6)
    deformed = rotate(rest, 12, (32, 24)) + (1.3, 0.4)
    frames = [comp.render([DrawLayer(key, image, off, rest, deformed, tri, np.zeros(len(rest)))], CANVAS,
                          size=(96, 72), background=WHITE)
              for key, image, off in (("whole", whole, im.offset), ("box", box, offset))]
    assert (frames[0] != 255).any()
    assert np.abs(frames[0].astype(int) - frames[1]).max() <= 1
