"""A scene of many layers keeps one built part per layer: the content caches grow with
the layer count instead of dropping parts every frame (a 20-layer 4K picture rebuilt
all 20 reduced preview images on every drag step when the store held 16)."""
import numpy as np

from puppet.scene.rig.cache import Memo
from puppet.scene.rig.core import PER_LAYER, Rig


def test_at_least_raises_capacity_and_never_lowers_it():
    m = Memo({"a": 4}, default=8)
    m.at_least(["a", "b"], 6)
    assert m.capacity == {"a": 6, "b": 8}
    m.at_least(["a"], 100)
    for i in range(100):
        m.get("a", str(i), lambda i=i: i)
    for i in range(100):  # all kept: nothing rebuilt
        assert m.get("a", str(i), lambda: -1) == i
    assert m.count("a") == 100
    m.at_least(["a"], 3)
    assert m.capacity["a"] == 100


def test_a_scene_of_many_layers_keeps_a_part_per_layer(tmp_path):
    from PIL import Image

    import puppet
    n = 80
    layers = []
    for k in range(n):
        a = np.zeros((20, 20, 4), np.uint8)
        a[4:16, 4:16] = (200, 40, 40, 255)
        Image.fromarray(a).save(tmp_path / f"l{k}.png")
        layers.append({"name": f"l{k}", "image": f"l{k}.png", "offset": [30 * (k % 8), 30 * (k // 8)]})
    import json
    (tmp_path / "s.json").write_text(json.dumps({"puppet": 1, "canvas": [240, 300], "layers": layers}))
    s = puppet.load_scene(str(tmp_path / "s.json"))
    rig = s.rig
    s.layers()
    built = rig.memo.count("mesh")
    assert built == n
    for kind in PER_LAYER:
        assert rig.memo.capacity[kind] >= 2 * n
    s.layers({})
    assert rig.memo.count("mesh") == n  # nothing rebuilt
    assert isinstance(rig, Rig)
