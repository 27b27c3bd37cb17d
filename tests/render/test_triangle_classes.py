"""The compositor's triangle classes (which triangles can be translucent, which draw
nothing) given with a layer instead of computed on upload: a scene keeps them in its
cache (kind ``"classes"``, on disk beside the scene), keyed by the layer's pixels, offset,
rest mesh and the classifying code; a stale, corrupt or misfit entry is never used; the
frames are bit-identical to those of a compositor that classifies by itself."""
from __future__ import annotations

import dataclasses
import glob
import os

import numpy as np
import pytest

import puppet
from puppet.render.layers import DrawLayer, check_layer, classes_fit, classify_triangles, texture_uv
from puppet.scene.rig import disk
from tests.conftest import bar_image
from tests.render.scenes import CANVAS, translucent_stack
from tests.scene.document.test_edits import three_bars

POSE = {"a2": [100, 8], "c1": [150, 58], "b1": [20, 75]}


def test_texture_uv_is_the_uploads_formula():
    rest = np.array([[3.0, 4.5], [10.25, 7.0], [0.0, 0.0]])
    uv = texture_uv(rest, (2, 1.5), (8, 16, 4))
    want = ((rest - (2.0, 1.5)) / (16, 8)).astype(np.float32)
    assert uv.dtype == np.float32 and np.array_equal(uv, want)


def test_classes_must_fit_the_triangles():
    layer = translucent_stack(1)[0]
    m = len(layer.triangles)
    good = (np.zeros(m, bool), np.ones(m, bool))
    assert classes_fit(good, m)
    check_layer(dataclasses.replace(layer, classes=good))
    for bad in [(np.zeros(m - 1, bool), np.zeros(m, bool)), (np.zeros(m, np.uint8), np.zeros(m, bool)),
                (np.zeros(m, bool),), [np.zeros(m, bool)] * 2]:
        assert not classes_fit(bad, m)
        with pytest.raises(ValueError, match="classes must be"):
            check_layer(dataclasses.replace(layer, classes=bad))


def _classes(layer: DrawLayer):
    return classify_triangles(layer.image, texture_uv(layer.rest, layer.offset, layer.image.shape),
                              layer.triangles)


@pytest.mark.gl
def test_given_classes_are_drawn_with_and_equal_computed_ones():
    from puppet.render.compositor import Compositor

    layers = translucent_stack(3)
    given = [dataclasses.replace(L, key=L.key + "+", classes=_classes(L)) for L in layers]
    comp = Compositor()
    try:
        want = comp.render(layers, CANVAS, background=(250, 250, 240, 255))
        assert np.array_equal(comp.render(given, CANVAS, background=(250, 250, 240, 255)), want)
        # they are really used: every triangle said empty draws nothing but the background
        m = [len(L.triangles) for L in layers]
        none = [dataclasses.replace(L, key=L.key + "-", classes=(np.zeros(k, bool), np.ones(k, bool)))
                for L, k in zip(layers, m)]
        blank = comp.render(none, CANVAS, background=(250, 250, 240, 255))
        assert (blank == (250, 250, 240, 255)).all() and not (want == blank).all()
    finally:
        comp.release()


# -- the scene's cache -------------------------------------------------------------------
@pytest.fixture
def bars(make_scene, monkeypatch):
    monkeypatch.setenv(disk.ENV, "on")
    return make_scene(three_bars(), {"bar.png": bar_image()})


def _open(path: str, *, cache: bool = True, monkeypatch=None):
    """(frame, classes built, classes read from disk) of a fresh open + render."""
    if not cache:
        monkeypatch.setenv(disk.ENV, "off")
    s = puppet.load_scene(path)
    try:
        frame = s.render(POSE)
    finally:
        s.close()
    disk.flush()
    if not cache:
        monkeypatch.setenv(disk.ENV, "on")
    store = s.rig.memo.disk
    return frame, s.rig.memo.count("classes"), (store.loads.get("classes", 0) if store else 0)


def _entries(path: str) -> list[str]:
    return sorted(glob.glob(os.path.join(os.path.dirname(path), disk.FOLDER, "classes-*.npz")))


@pytest.mark.gl
def test_a_second_open_reads_the_classes_and_draws_the_same_bits(bars, monkeypatch):
    want, built, _ = _open(bars, cache=False, monkeypatch=monkeypatch)
    assert built == 3 and not _entries(bars)
    first, built, loads = _open(bars)
    assert built == 3 and loads == 0 and len(_entries(bars)) == 3
    second, built, loads = _open(bars)
    assert built == 0 and loads == 3
    assert np.array_equal(first, want) and np.array_equal(second, want)


@pytest.mark.gl
def test_corrupt_and_misfit_entries_are_not_used(bars, monkeypatch):
    want = _open(bars, cache=False, monkeypatch=monkeypatch)[0]
    _open(bars)
    paths = _entries(bars)
    with open(paths[0], "wb") as f:  # corrupt: rebuilt
        f.write(b"not an npz")
    frame, built, loads = _open(bars)
    assert np.array_equal(frame, want) and built == 1 and loads == 2
    # a well-formed entry under the right key whose arrays do not fit the mesh (hostile):
    # the compositor classifies by itself, the frame stays exact
    s = puppet.load_scene(bars)
    r, im, k = s.layers(POSE)[0], s.built.images[0], s.built.image_keys[0]
    s._triangle_classes(r, im.drawn, k)
    key = next(iter(s.rig.memo._stores["classes"]))
    s.close()
    disk.flush()
    assert s.rig.memo.disk.save("classes", key, (np.zeros(1, bool), np.zeros(1, bool)))
    frame, built, loads = _open(bars)
    assert np.array_equal(frame, want) and loads == 3


def test_each_input_asks_for_another_entry(bars, monkeypatch):
    s = puppet.load_scene(bars)
    r, im, k = s.layers(POSE)[2], s.built.images[2], s.built.image_keys[2]
    image, offset = im.drawn
    base = s._triangle_classes(r, im.drawn, k)
    assert s.rig.memo.count("classes") == 1
    assert s._triangle_classes(r, im.drawn, k) is base and s.rig.memo.count("classes") == 1
    rest = r.rest + 0.0  # the same values: the same entry
    assert s._triangle_classes(dataclasses.replace(r, rest=rest), im.drawn, k) is base
    changes = [(dataclasses.replace(r, rest=r.rest + (0.0, 2.0)), im.drawn, k),
               (dataclasses.replace(r, triangles=r.triangles[::-1].copy()), im.drawn, k),
               (r, (image, (offset[0] + 1, offset[1])), k),
               (r, (image[:, :-1], offset), k),
               (r, im.drawn, k + "0")]
    for n, args in enumerate(changes, 2):
        got = s._triangle_classes(*args)
        assert s.rig.memo.count("classes") == n
        r2, (img2, off2), _ = args
        want = classify_triangles(img2, texture_uv(r2.rest, off2, img2.shape), r2.triangles)
        assert all(np.array_equal(a, b) for a, b in zip(got, want))
    monkeypatch.setattr(puppet.api, "_classifier_stamp", lambda: ["another classifier"])
    s._classes.clear()  # (looked up once per mesh version)
    s._triangle_classes(r, im.drawn, k)
    assert s.rig.memo.count("classes") == len(changes) + 2
    s.close()
