"""The bundled scenes' poses where plain ARAP folds triangles come out fold-free."""
import numpy as np
import pytest

import puppet
from puppet.deform.relax import folded_triangles
from tests.conftest import SCENES

# poses where plain ARAP folds triangles on the bundled scenes
CASES = [("trex-layers", "roar"), ("character", "behind")]  # (character "wave" folded until outlines reached the images' last rows and columns)


@pytest.fixture(scope="module")
def scenes():
    return {name: puppet.load_scene(f"{SCENES}/{name}.json") for name in {s for s, _ in CASES}}


def solve(sc, pose, relax):
    sc.data.deformer.relax_foldovers = relax  # read by the solver at every pose
    try:
        return sc.layers(pose)
    finally:
        sc.data.deformer.relax_foldovers = True


def folds(layers):
    return [folded_triangles(r.rest, r.deformed, r.triangles) for r in layers]


@pytest.mark.parametrize("scene,pose", CASES)
def test_no_folds_with_relax_and_some_without(scenes, scene, pose):
    sc = scenes[scene]
    assert sc.data.deformer.relax_foldovers, "on by default"
    off = solve(sc, pose, False)
    assert sum(len(f) for f in folds(off)) > 0, "plain ARAP folds here (the reason relax exists)"
    on = solve(sc, pose, True)
    assert sum(len(f) for f in folds(on)) == 0


@pytest.mark.parametrize("scene,pose", CASES)
def test_pins_exactly_on_their_targets(scenes, scene, pose):
    sc = scenes[scene]
    target = dict(zip((p.name for p in sc.data.pins), sc.state(pose).to))
    n = 0
    for r in solve(sc, pose, True):
        for name, v in r.pins.items():
            assert np.array_equal(r.deformed[v], target[name]), (r.name, name)
            n += 1
    assert n > 0


@pytest.mark.parametrize("scene,pose", [("trex-layers", "roar")])
def test_relaxing_is_local(scenes, scene, pose):
    """Vertices 160 px or more from every folded triangle move less than 1 px."""
    sc = scenes[scene]
    off, on = solve(sc, pose, False), solve(sc, pose, True)
    bad = np.concatenate([r.deformed[r.triangles[f]].reshape(-1, 2) for r, f in zip(off, folds(off))])
    checked = 0
    for a, b in zip(off, on):
        far = np.linalg.norm(a.deformed[:, None] - bad[None], axis=2).min(axis=1) >= 160
        if far.any():
            assert np.abs(b.deformed[far] - a.deformed[far]).max() < 1.0, a.name
        checked += far.sum()
    assert checked > 100


@pytest.mark.parametrize("scene", sorted({s for s, _ in CASES}))
def test_rest_pose_is_the_rest_mesh(scenes, scene):
    for r in solve(scenes[scene], "rest", True):
        assert np.abs(r.deformed - r.rest).max() < 1e-9


def test_rest_is_exact_on_the_cut_out_trex():
    """Its polygon layers mesh with negative cotangent weights: rest must still be rest."""
    sc = puppet.load_scene(f"{SCENES}/trex-cutout-inpaint.json")
    sc.data.deformer.relax_foldovers = False
    for r in sc.layers():
        assert np.abs(r.deformed - r.rest).max() < 1e-9
