"""Layers cut from one picture: inpainting through a real render, self-overlap, rings, GrabCut."""
import numpy as np
import pytest

import puppet
from puppet.imaging import masks as mk

pytestmark = pytest.mark.gl


def picture():
    """A green body with a red arm painted over it, on white."""
    a = np.full((100, 160, 4), 255, np.uint8)
    a[20:80, 20:140, :3] = (40, 160, 60)
    a[45:55, 30:110, :3] = (200, 30, 30)
    return a


@pytest.mark.parametrize("method", ["pyramid", "telea", "ns", "fsr"])
def test_moved_part_uncovers_the_layer_beneath(make_scene, method):
    s = {"puppet": 1, "source": "pic.png", "background": [255, 255, 255, 255],
         "layers": [{"name": "body", "mask": {"threshold": 250}, "inpaint": method},
                    {"name": "arm", "mask": {"rect": [30, 45, 80, 10]}}],
         "links": [{"layers": ["body", "arm"], "segments": [[[100, 48], [100, 52]]]}],
         "pins": [{"name": "hip", "layer": "body", "at": [120, 70]}, {"name": "top", "layer": "body", "at": [60, 28]},
                  {"name": "hand", "layer": "arm", "at": [35, 50]}],
         "poses": {"raise": {"hand": [60, 5]}}}
    sc = puppet.load_scene(make_scene(s, {"pic.png": picture()}, name=f"{method}.json"))
    img = sc.render(pose="raise")
    (arm,) = [r for r in sc.layers("raise") if r.name == "arm"]
    # where the hand was: now uncovered (the arm moved up and away)
    patch = img[46:54, 34:50, :3].astype(int)
    assert np.abs(patch - [40, 160, 60]).max() < 40, f"{method}: {patch.mean((0, 1))}"
    assert (img[46:54, 34:50, 3] == 255).all()
    # and the arm is drawn where it went
    hx, hy = arm.deformed[arm.pins["hand"]]
    assert tuple(img[int(hy), int(hx), :3]) == (200, 30, 30)


def test_without_inpainting_the_copy_stays_behind(make_scene):
    s = {"puppet": 1, "source": "pic.png",
         "layers": [{"name": "body", "mask": {"threshold": 250}},
                    {"name": "arm", "mask": {"rect": [30, 45, 80, 10]}}],
         "links": [{"layers": ["body", "arm"], "segments": [[[100, 48], [100, 52]]]}],
         "pins": [{"name": "hip", "layer": "body", "at": [120, 70]}, {"name": "top", "layer": "body", "at": [60, 28]},
                  {"name": "hand", "layer": "arm", "at": [35, 50]}],
         "poses": {"raise": {"hand": [60, 5]}}}
    img = puppet.load_scene(make_scene(s, {"pic.png": picture()})).render(pose="raise")
    assert (img[46:54, 34:50, :3] == (200, 30, 30)).all()


def gradient_strip():
    """A long strip whose colour runs from red (left) to blue (right)."""
    a = np.zeros((200, 300, 4), np.uint8)
    t = np.linspace(0, 1, 280)
    a[90:110, 10:290, 0] = (230 * (1 - t)).astype(np.uint8)
    a[90:110, 10:290, 2] = (230 * t).astype(np.uint8)
    a[90:110, 10:290, 3] = 255
    return a


@pytest.mark.parametrize("left_depth,right_depth", [(1.0, -1.0), (-1.0, 1.0)])
def test_strip_folded_over_itself_shows_the_higher_part(make_scene, left_depth, right_depth):
    """The interlaced-rope case: one layer crossing itself, pin depths decide the crossing."""
    s = {"puppet": 1, "canvas": [300, 200], "background": [255, 255, 255, 255],
         "layers": [{"name": "rope", "image": "rope.png"}],
         "pins": [{"name": "a", "layer": "rope", "at": [20, 100], "depth": left_depth},
                  {"name": "m1", "layer": "rope", "at": [110, 100]},
                  {"name": "m2", "layer": "rope", "at": [200, 100]},
                  {"name": "b", "layer": "rope", "at": [280, 100], "depth": right_depth}],
         "poses": {"cross": {"a": [40, 100], "m1": [150, 100], "m2": [170, 160], "b": [90, 40]}}}
    sc = puppet.load_scene(make_scene(s, {"rope.png": gradient_strip()}, name=f"r{left_depth}.json"))
    (r,) = sc.layers("cross")
    img = sc.render(pose="cross").astype(int)
    # pixels covered by both a left-end (red) triangle and a right-end (blue) triangle
    both = coverage(r, r.rest[:, 0] < 110, img.shape[:2]) & coverage(r, r.rest[:, 0] > 190, img.shape[:2])
    assert both.sum() > 20, "the two ends cross"
    ys, xs = np.nonzero(both)
    px = img[ys, xs, :3].mean(0)
    if left_depth > right_depth:
        assert px[0] > px[2] + 60, px   # the red (left) end on top
    else:
        assert px[2] > px[0] + 60, px   # the blue (right) end on top


def coverage(r, vertex_mask, shape):
    """Pixels (centres) inside any deformed triangle whose vertices all satisfy vertex_mask,
    shrunk by a pixel so that edges do not count."""
    h, w = shape
    out = np.zeros(shape, bool)
    for t in r.triangles[vertex_mask[r.triangles].all(1)]:
        a, b, c = r.deformed[t]
        lo = np.floor(np.minimum(np.minimum(a, b), c)).astype(int)
        hi = np.ceil(np.maximum(np.maximum(a, b), c)).astype(int)
        xs, ys = np.meshgrid(np.arange(max(lo[0], 0), min(hi[0], w)), np.arange(max(lo[1], 0), min(hi[1], h)))
        P = np.stack([xs + 0.5, ys + 0.5], -1)
        d = (b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0]
        if abs(d) < 1e-9:
            continue
        l1 = ((P[..., 0] - a[0]) * (c - a)[1] - (P[..., 1] - a[1]) * (c - a)[0]) / d
        l2 = ((b - a)[0] * (P[..., 1] - a[1]) - (b - a)[1] * (P[..., 0] - a[0])) / d
        inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        out[ys[inside], xs[inside]] = True
    from scipy.ndimage import binary_erosion
    return binary_erosion(out, iterations=1)


def test_ring_keeps_its_hole_after_deformation(make_scene):
    yy, xx = np.mgrid[:120, :120] + 0.5
    d = np.hypot(xx - 60, yy - 60)
    a = np.zeros((120, 120, 4), np.uint8)
    a[(d < 50) & (d > 25)] = (30, 30, 30, 255)
    s = {"puppet": 1, "canvas": [120, 120], "background": [255, 255, 255, 255],
         "layers": [{"name": "ring", "image": "ring.png"}],
         "pins": [{"name": "l", "layer": "ring", "at": [20, 60]}, {"name": "r", "layer": "ring", "at": [100, 60]}],
         "poses": {"stretch": {"l": [12, 60], "r": [108, 60]}}}
    sc = puppet.load_scene(make_scene(s, {"ring.png": a}))
    (r,) = sc.layers("stretch")
    cent = r.rest[r.triangles].mean(1)
    assert (np.hypot(cent[:, 0] - 60, cent[:, 1] - 60) > 23).all()
    img = sc.render(pose="stretch")
    assert tuple(img[60, 60, :3]) == (255, 255, 255), "the hole shows the background"
    assert tuple(img[60, 15, :3]) == (30, 30, 30)


def test_grabcut_finds_the_object_in_a_photo():
    rng = np.random.default_rng(0)
    img = np.zeros((80, 100, 4), np.uint8)
    img[..., :3] = rng.integers(150, 200, (80, 100, 3))
    img[..., 3] = 255
    yy, xx = np.mgrid[:80, :100]
    obj = (xx - 50) ** 2 / 20**2 + (yy - 40) ** 2 / 25**2 < 1
    img[obj, :3] = rng.integers(10, 60, (obj.sum(), 3))
    m = mk.grabcut_mask(img, [20, 8, 60, 64])
    iou = (m & obj).sum() / (m | obj).sum()
    assert iou > 0.9, iou
