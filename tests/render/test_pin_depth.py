"""``Compositor.pin_depth`` (the GPU's per-pixel pin depth) against its CPU reference,
``tests/room/reference.py`` (``layer_depth`` and the front-most layer of
``front_depth``), on small random layers."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.render.layers import DrawLayer
from tests.room.reference import layer_depth

SIZE = (48, 40)


def grid_layer(rng, key: str, offset, shape=(9, 11), step=3.0) -> DrawLayer:
    """A jittered grid mesh over a texture with clear holes, moved by a random affine map
    (no fold), with random vertex depths."""
    h, w = shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    rest = np.stack([xs.ravel(), ys.ravel()], axis=1) * step + offset + rng.uniform(-0.4, 0.4, (h * w, 2))
    tris = []
    for r in range(h - 1):
        for c in range(w - 1):
            i = r * w + c
            tris += [[i, i + 1, i + w + 1], [i, i + w + 1, i + w]]
    th, tw = int((h - 1) * step) + 2, int((w - 1) * step) + 2
    image = np.zeros((th, tw, 4), np.uint8)
    image[..., :3] = 200
    image[..., 3] = np.where(rng.random((th, tw)) < 0.2, 0, 255)  # clear texels: no depth there
    A = np.array([[1.1, 0.2], [-0.15, 0.95]]) + rng.uniform(-0.05, 0.05, (2, 2))
    deformed = (rest - rest.mean(axis=0)) @ A.T + rest.mean(axis=0) + rng.uniform(-2, 2, 2)
    return DrawLayer(key=key, image=image, offset=(float(offset[0]), float(offset[1])),
                     rest=rest, deformed=deformed, triangles=np.array(tris), depth=rng.uniform(-2, 2, h * w))


@pytest.mark.gl
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pin_depth_matches_the_cpu_reference(seed):
    from puppet.render.compositor import Compositor

    rng = np.random.default_rng(seed)
    layers = [grid_layer(rng, "back", (4.0, 5.0)), grid_layer(rng, "front", (14.0, 9.0))]
    ranks = [0.0, 1.5]
    for L, r in zip(layers, ranks):
        L.depth[:] += r  # a layer's depth is its rank plus what its pins give
    comp = Compositor()
    try:
        gl = comp.pin_depth(layers, SIZE, ranks)
        # after a composite of other layers the same call gives the same map (its own targets)
        comp.render(layers, SIZE)
        again = comp.pin_depth(layers, SIZE, ranks)
    finally:
        comp.release()
    assert gl.shape == (SIZE[1], SIZE[0]) and gl.dtype == np.float32
    assert np.array_equal(np.isnan(gl), np.isnan(again)) and np.allclose(gl, again, equal_nan=True)
    per = [layer_depth(L.deformed, L.rest, L.triangles, L.depth - r, L.image, L.offset, SIZE)
           for L, r in zip(layers, ranks)]
    stack = np.stack([np.where(np.isnan(p), -np.inf, p + r) for p, r in zip(per, ranks)])
    front = np.take_along_axis(np.stack(per), stack.argmax(axis=0)[None], axis=0)[0]
    cpu = np.where(np.isfinite(stack.max(axis=0)), front, np.nan)
    shown = ~np.isnan(cpu)
    assert shown.sum() > 400 and (~shown).sum() > 100  # layers, holes and clear canvas
    agree = np.isnan(gl) == np.isnan(cpu)
    assert agree.mean() > 0.995  # a texel or triangle boundary through a pixel centre may differ in float32
    both = ~np.isnan(gl) & ~np.isnan(cpu)
    assert np.abs(gl[both] - cpu[both]).max() < 1e-3  # float32 interpolation
    # both layers show somewhere, and the front one's pins are read where it covers the back one
    assert np.isclose(gl[both], per[1][both], atol=1e-4).sum() > 50 and np.isclose(gl[both], per[0][both],
                                                                                   atol=1e-4).sum() > 50
