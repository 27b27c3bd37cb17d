"""Compositor frame time on the T-rex scene, beside its floor measured in the same run.

Run: ``python benchmarks/bench_render.py [--frames N] [--scene PATH]`` from the
repository root. The scene's poses are solved once; every timed frame draws the next pose
(new positions and depths). Per output size, interleaved frame by frame so that all
columns see the same machine load:

* **floor**: a plain single-pass depth-tested textured draw of the same meshes (no
  discard, no blending) into an RGBA8 + depth framebuffer, then ``glFinish``;
* **final**: ``Compositor.render`` with DrawLayers, as ``Scene.render`` calls it (upload
  checks, every pass, the read-back into a numpy array);
* **no read-back**: the same frame drawn by ``Compositor.draw`` into a texture, then
  ``glFinish``; **read-back**: reading that finished texture into a numpy array;
* **preview**: what a drag does per frame: ``Compositor.update`` of every layer's
  positions and depths, ``Compositor.draw`` into a texture, ``glFinish``.

Times are medians in ms. A ratio is the median over frames of (time / the floor's time in
the same round), which cancels most of the drift of a shared machine's load.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import moderngl
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import puppet  # noqa: E402
from puppet.render.compositor import Compositor, DrawLayer  # noqa: E402
from puppet.render.layers import depth_window, premultiply  # noqa: E402

SIZES = [(600, 500), (1280, 800), (1920, 1080)]
FLOOR_VS = """#version 330 core
uniform vec2 u_canvas;
uniform vec2 u_depth;
in vec2 in_pos;
in float in_depth;
in vec2 in_uv;
out vec2 v_uv;
void main() {
    v_uv = in_uv;
    float z = (u_depth.x - in_depth) * u_depth.y;
    gl_Position = vec4(in_pos / u_canvas * 2.0 - 1.0, 2.0 * z - 1.0, 1.0);
}
"""
FLOOR_FS = """#version 330 core
uniform sampler2D u_texture;
in vec2 v_uv;
out vec4 f_color;
void main() { f_color = texture(u_texture, v_uv); }
"""


def scene_frames(path: str) -> tuple[tuple[int, int], tuple, list[list[DrawLayer]]]:
    """Canvas, background and one DrawLayer list per pose (rest first)."""
    scene = puppet.load_scene(path)
    images = getattr(scene, "images", None) or scene.built.images
    frames = []
    for pose in [None, *scene.data.poses]:
        frames.append([DrawLayer(r.name, im.rgba, im.offset, r.rest, r.deformed, r.triangles,
                                 r.depth) for r, im in zip(scene.layers(pose), images)])
    return scene.canvas, tuple(scene.background()), frames


class Floor:
    """The plain depth-tested textured draw of the same meshes (static index buffers,
    vertices rewritten per frame like the compositor's)."""

    def __init__(self, ctx: moderngl.Context, layers: list[DrawLayer], canvas):
        self.ctx = ctx
        self.prog = ctx.program(vertex_shader=FLOOR_VS, fragment_shader=FLOOR_FS)
        self.prog["u_canvas"].value = tuple(float(v) for v in canvas)
        self.items = []
        for layer in layers:
            h, w = layer.image.shape[:2]
            tex = ctx.texture((w, h), 4, np.ascontiguousarray(premultiply(layer.image)))
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            uv = ctx.buffer(((layer.rest - layer.offset) / (w, h)).astype(np.float32))
            vbo = ctx.buffer(reserve=len(layer.rest) * 12)
            ibo = ctx.buffer(np.asarray(layer.triangles, np.int32))
            vao = ctx.vertex_array(self.prog, [(vbo, "2f 1f", "in_pos", "in_depth"),
                                               (uv, "2f", "in_uv")],
                                   index_buffer=ibo, index_element_size=4)
            self.items.append((tex, vbo, vao))
        self.fbo = None

    def draw(self, layers: list[DrawLayer], size) -> None:
        ctx = self.ctx
        if self.fbo is None or self.fbo.size != size:
            self.fbo = ctx.framebuffer([ctx.texture(size, 4)], ctx.depth_renderbuffer(size))
        lo = min(float(np.min(layer.depth)) for layer in layers)
        hi = max(float(np.max(layer.depth)) for layer in layers)
        self.prog["u_depth"].value = depth_window(lo, hi)
        for layer, (_, vbo, _) in zip(layers, self.items):
            vbo.write(np.concatenate([layer.deformed, layer.depth[:, None]], 1).astype(np.float32))
        self.fbo.use()
        self.fbo.clear(1.0, 1.0, 1.0, 1.0, depth=1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        order = np.argsort([-float(np.mean(layer.depth)) for layer in layers])  # near first
        for i in order:
            tex, _, vao = self.items[i]
            tex.use(0)
            vao.render(moderngl.TRIANGLES)
        ctx.finish()


def bench_size(ctx, comp, floor, canvas, background, frames, size, n):
    target = ctx.texture(size, 4)
    keys = [layer.key for layer in frames[0]]
    times = {"floor": [], "final": [], "draw": [], "read": [], "preview": []}
    pixels = np.empty((size[1], size[0], 4), np.uint8)
    methods = set()
    for k in range(n + 1):
        layers = frames[k % len(frames)]
        t0 = time.perf_counter()
        floor.draw(layers, size)
        t1 = time.perf_counter()
        comp.render(layers, canvas, size=size, background=background)
        t2 = time.perf_counter()
        comp.draw(layers, canvas, target=target, background=background)
        ctx.finish()
        t3 = time.perf_counter()
        target.read_into(pixels)
        t3, t3r = time.perf_counter(), t3
        nxt = frames[(k + 1) % len(frames)]
        for layer in nxt:
            comp.update(layer.key, deformed=layer.deformed, depth=layer.depth)
        comp.draw(keys, canvas, target=target, background=background)
        ctx.finish()
        t4 = time.perf_counter()
        methods.add(comp.last_method)
        if k:  # the first round uploads textures and compiles: not timed
            for name, dt in zip(times, (t1 - t0, t2 - t1, t3r - t2, t3 - t3r, t4 - t3)):
                times[name].append(dt * 1000)
    target.release()
    med = {name: statistics.median(v) for name, v in times.items()}
    ratio = {name: statistics.median(np.divide(v, times["floor"])) for name, v in times.items()}
    readback = med["read"]
    print(f"| {f'{size[0]}x{size[1]}':<9} | {med['floor']:7.1f} | {med['final']:7.1f} | "
          f"{ratio['final']:5.2f}x | {med['draw']:7.1f} | {ratio['draw']:5.2f}x | {readback:5.1f} "
          f"({100 * readback / med['final']:2.0f} %) | {med['preview']:7.1f} | "
          f"{ratio['preview']:5.2f}x | {'/'.join(sorted(methods))} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--scene", default="assets/scenes/trex-layers.json")
    parser.add_argument("--method", default="auto", choices=["auto", "kbuffer", "abuffer"],
                        help="edge method (abuffer: what a GPU without framebuffer fetch runs)")
    args = parser.parse_args(argv)
    canvas, background, frames = scene_frames(args.scene)
    comp = Compositor(method=args.method)
    ctx = comp.ctx
    tris = sum(len(layer.triangles) for layer in frames[0])
    with ctx:
        floor = Floor(ctx, frames[0], canvas)
        print(f"{args.scene}: {len(frames[0])} layers, {tris} triangles, canvas "
              f"{canvas[0]}x{canvas[1]}, {len(frames)} poses; {args.frames} frames per row; "
              f"{ctx.info['GL_RENDERER']}, LP_NUM_THREADS="
              f"{os.environ.get('LP_NUM_THREADS', '(default)')}, {os.cpu_count()} CPUs")
        print("| size      | floor ms | final ms | final/floor | no read-back ms | /floor "
              "| read-back ms (of final) | preview ms | /floor | method |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for size in SIZES:
            bench_size(ctx, comp, floor, canvas, background, frames, size, args.frames)
    comp.release()


if __name__ == "__main__":
    main()
