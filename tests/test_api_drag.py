"""Dragging a pin: fast previews, an exact release equal to render(pose=...), one undo step."""
from __future__ import annotations

import numpy as np
import pytest

import puppet
from tests.conftest import SCENES

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def trex():
    scene = puppet.load_scene(SCENES + "/trex-layers.json")
    yield scene
    scene.close()


def test_release_is_exactly_the_rendered_pose(trex):
    trex.set_active_pose("wave")
    before = trex.to_dict()
    steps = len(trex.history.undo_stack)
    d = trex.drag("hand_front")
    path = [(100 + 5 * i, 200 - 3 * i) for i in range(8)]
    previews = [d.move(xy) for xy in path]
    assert all(p.shape == (500, 600, 4) and p.dtype == np.uint8 for p in previews)
    assert not np.array_equal(previews[0], previews[-1])
    final = d.release()
    pose = trex.to_dict()["poses"]["wave"]
    assert pose["hand_front"] == list(map(float, path[-1])) or pose["hand_front"]["to"] == list(map(float, path[-1]))
    np.testing.assert_array_equal(final, trex.render(pose=pose))
    np.testing.assert_array_equal(final, trex.render())
    # a fresh scene given the same targets draws the same pixels (trajectory invariance)
    fresh = puppet.load_scene(SCENES + "/trex-layers.json")
    try:
        np.testing.assert_array_equal(final, fresh.render(pose=pose))
    finally:
        fresh.close()
    # the whole drag is one undo step
    assert len(trex.history.undo_stack) == steps + 1
    trex.undo()
    assert trex.to_dict() == before


def test_preview_follows_the_pin(trex):
    trex.set_active_pose("wave")
    d = trex.drag("hand_front")
    xy = np.array([150.0, 180.0])
    for k in range(6):
        layers = d.move_layers(xy + k)
    r = next(r for r in layers if "hand_front" in r.pins)
    np.testing.assert_allclose(r.deformed[r.pins["hand_front"]], xy + 5, atol=1e-9)
    d.cancel()
    assert not d.open


def test_every_drag_kind_releases_the_rendered_frame(trex):
    trex.set_active_pose("roar")
    d = trex.drag(["hand_front", "tail_tip", "jaw"])
    for k in range(4):
        d.move({"hand_front": (100 + 4 * k, 200), "tail_tip": (560, 240 - 3 * k), "jaw": (330, 110 + k)})
    final = d.release()
    np.testing.assert_array_equal(final, trex.render(pose=trex.to_dict()["poses"]["roar"]))
    d = trex.drag(["hand_front", "jaw"], time=0.8)
    for k in range(4):
        d.move({"hand_front": (110 + 4 * k, 190), "jaw": (320, 100 + k)})
    np.testing.assert_array_equal(d.release(), trex.render(time=0.8))
    d = trex.drag("tail_tip", time=0.1, record=True)
    for k in range(4):
        d.move((540 + 3 * k, 250), time=0.1 + 0.1 * k)
    np.testing.assert_array_equal(d.release({0.1: {"tail_tip": (540, 250)}, 0.4: {"tail_tip": (549, 250)}}),
                                  trex.render(time=0.1))


def test_preview_frames_are_bounded():
    from puppet.api import PREVIEW_PIXELS, preview_size

    assert preview_size((600, 500)) == (600, 500)
    w, h = preview_size((4000, 4000))
    assert w == h and w * h <= PREVIEW_PIXELS and (w + 1) * (h + 1) > PREVIEW_PIXELS
    w, h = preview_size((8000, 2000))
    assert w * h <= PREVIEW_PIXELS and abs(w / h - 4) < 0.01


def test_bad_drags_are_user_errors(trex):
    with pytest.raises(puppet.SceneError, match="no pin"):
        trex.drag("nobody")
    d = trex.drag("hand_front")
    with pytest.raises(puppet.SceneError, match="finite"):
        d.move((np.nan, 1))
    d.release()
    with pytest.raises(puppet.SceneError, match="released"):
        d.move((1, 1))


def test_reduced_preview_looks_like_the_full_one(trex):
    trex.set_active_pose("wave")
    layers = trex.layers()
    full = trex.draw_layers(layers, size=(300, 250)).astype(float)
    small = trex.draw_layers(layers, size=(300, 250), reduce=2).astype(float)
    assert full.shape == small.shape
    assert np.abs(full - small).mean() < 2.0  # the same picture, resampled
    assert (small[..., 3] > 0).sum() > 0.9 * (full[..., 3] > 0).sum()


def test_big_picture_path_releases_the_rendered_frame(monkeypatch):
    """The cheap path of big pictures (a reduced model's coarse mesh, frames from shrunk
    images), forced on the horse: previews drawn from it, the release exactly ``render``."""
    import puppet.api
    from puppet.scene.rig import reduced

    monkeypatch.setattr(reduced, "REDUCED_MIN", 500)
    monkeypatch.setattr(reduced, "REDUCED_VERTICES", 300)
    monkeypatch.setattr(puppet.api, "PREVIEW_PIXELS", 160 * 120)
    scene = puppet.load_scene(SCENES + "/horse.json")
    try:
        d = scene.drag(["head", "tail"])
        assert d.reduce >= 2 and d.preview_size[0] * d.preview_size[1] <= 160 * 120
        at = {p.name: np.asarray(p.at) for p in scene.data.pins}
        frames = [d.move({"head": at["head"] + [4 * k, -3 * k], "tail": at["tail"] + [-2 * k, 0]}) for k in range(1, 4)]
        assert all(f.shape == (d.preview_size[1], d.preview_size[0], 4) for f in frames)
        assert set(d._detail) == {0}  # previewed on the reduced model
        assert not np.array_equal(frames[0], frames[-1]) and frames[-1][..., 3].any()
        final = d.release()
        np.testing.assert_array_equal(final, scene.render())
        np.testing.assert_array_equal(final, scene.render(pose=scene.to_dict()["poses"][scene.active_pose]))
    finally:
        scene.close()
