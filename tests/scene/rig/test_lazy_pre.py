"""``Rig.build(data, lazy_pre=True)``: the groups' precomputations are made (or read from
the disk cache) on the first solve that needs them, all together, once; a scene's first
render builds so, and a pose the disk cache holds then needs none of them. Every result is
bit-identical to an eager build's."""
from __future__ import annotations

import threading

import numpy as np
import pytest

import puppet
from puppet.scene.document.core import Document
from puppet.scene.rig import disk
from puppet.scene.rig.core import _AllLazy
from tests.conftest import bar_image
from tests.scene.document.test_edits import three_bars

FIRST = {"a2": [100, 8], "c1": [150, 58], "b1": [20, 75]}
OTHER = {"a2": [96, 30], "c1": [140, 40], "b1": [25, 60]}


def same(x, y):
    assert len(x) == len(y)
    for r, s in zip(x, y):
        for a in ("rest", "deformed", "triangles", "depth"):
            assert np.array_equal(getattr(r, a), getattr(s, a)), (r.name, a)


def test_all_lazy_makes_every_item_once_on_first_use():
    calls = []
    barrier = threading.Barrier(4)

    def make():
        calls.append(1)
        return ["a", "b", "c"]

    items = _AllLazy(3, make)
    assert len(items) == 3 and calls == []
    got = []

    def use(k):
        barrier.wait()
        got.append(items[k])

    threads = [threading.Thread(target=use, args=(k % 3,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert calls == [1] and sorted(got) == ["a", "a", "b", "c"] and items[-1] == "c"


def test_a_lazy_build_solves_as_an_eager_one(make_scene):
    path = make_scene(three_bars(), {"bar.png": bar_image()})
    eager, lazy = Document.load(path), Document.load(path)
    lazy._built = lazy.rig.build(lazy.data, lazy_pre=True)
    assert lazy.rig.memo.count("precompute") == 0
    same(lazy.layers(FIRST), eager.layers(FIRST))
    assert lazy.rig.memo.count("precompute") == 2  # both groups, on the first solve
    same(lazy.layers(OTHER), eager.layers(OTHER))
    assert lazy.rig.memo.count("precompute") == 2


@pytest.mark.gl
def test_a_first_render_from_the_cache_reads_no_precomputation(make_scene, monkeypatch):
    monkeypatch.setenv(disk.ENV, "on")
    path = make_scene(three_bars(), {"bar.png": bar_image()})

    def opened():
        s = puppet.load_scene(path)
        frame = s.render(FIRST)
        return s, frame

    s, want = opened()  # cold: solved, so precomputed, and the pose kept on disk
    s.close()
    disk.flush()
    assert s.rig.memo.count("precompute") == 2
    s, frame = opened()
    try:
        assert np.array_equal(frame, want)
        assert s.rig.memo.count("precompute") == 0 and "precompute" not in s.rig.memo.disk.loads
        same(s.layers(OTHER), Document.load(path).layers(OTHER))  # a new pose: read them now
        assert s.rig.memo.disk.loads["precompute"] == 2 and s.rig.memo.count("precompute") == 0
    finally:
        s.close()
