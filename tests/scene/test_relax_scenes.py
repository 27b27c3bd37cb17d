"""The bundled scenes' poses where plain ARAP folds triangles come out fold-free."""
import numpy as np
import pytest

import puppet
from puppet.deform.relax import folded_triangles
from tests.conftest import SCENES


@pytest.mark.parametrize("scene,pose", [("trex-cutout", "reach"), ("trex-layers", "roar"), ("trex-layers", "tuck")])
def test_no_folds_with_relax_and_some_without(scene, pose):
    sc = puppet.load_scene(f"{SCENES}/{scene}.json")
    on = sum(len(folded_triangles(r.rest, r.deformed, r.triangles)) for r in sc.layers(pose))
    assert on == 0
    sc.data.deformer.relax_foldovers = False
    sc2 = puppet.load_scene(f"{SCENES}/{scene}.json")
    sc2.data.deformer.relax_foldovers = False
    off = sum(len(folded_triangles(r.rest, r.deformed, r.triangles)) for r in sc2.layers(pose))
    assert off > 0, "plain ARAP folds here (the reason relax exists)"
    for r in sc.layers(pose):
        for name, v in r.pins.items():
            assert np.isfinite(r.deformed[v]).all()
