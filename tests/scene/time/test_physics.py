"""Secondary motion (issue 35 item 2): ``physics.chains`` read and refused by path, the
chains stepped deterministically at a fixed rate, decaying to the animated pose, solved
in the frames of either in-between mode, renamed and removed with their pins; scenes
without physics exactly as before."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import puppet
from puppet.errors import SceneError
from puppet.scene.time.physics import RATE, chain_paths, pin_paths
from puppet.scene.time.tracks import state_at
from tests.conftest import bar_image

TAIL = [(20, 30), (80, 30), (140, 30), (200, 30)]  # pins along the bar, anchor first
CHAIN = {"pins": ["t0", "t1", "t2", "t3"], "frequency": 2.0, "damping": 0.3}
STOP = 1.0  # the anchor stops here


def tail_scene(physics=None, inbetween="rigid") -> dict:
    """A 200 x 20 px bar with four pins; the anchor pin swings up and down until STOP s,
    then the animation holds until 4 s."""
    s = {"puppet": 1, "canvas": [240, 120], "background": [255, 255, 255, 255],
         "layers": [{"name": "tail", "image": "tail.png", "offset": [10, 20], "mesh": {"max_area": 60}}],
         "pins": [{"name": f"t{i}", "layer": "tail", "at": list(at)} for i, at in enumerate(TAIL)],
         "animation": {"fps": 24, "inbetween": inbetween, "keys": [
             {"time": 0, "pins": {"t0": [20, 30]}},
             {"time": 0.4, "pins": {"t0": [20, 70]}, "ease": "smooth"},
             {"time": STOP, "pins": {"t0": [20, 10]}, "ease": "smooth"},
             {"time": 4.0, "pins": {"t0": [20, 10]}}]}}
    if physics is not None:
        s["physics"] = physics
    return s


@pytest.fixture
def scene(make_scene):
    def make(s: dict) -> str:
        return make_scene(s, {"tail.png": bar_image(220, 40, (5, 5, 215, 25))})
    return make


def pins_at(doc, t: float) -> np.ndarray:
    L = doc.layers(time=t)[0]
    return np.array([L.deformed[L.pins[f"t{i}"]] for i in range(4)])


def test_chains_are_deterministic_whatever_the_frame_rate_or_order(scene):
    path = scene(tail_scene({"chains": [CHAIN]}))
    a, b = puppet.load_scene(path), puppet.load_scene(path)
    times24 = [i / 24 for i in range(48)]  # i / 24 == j / 60 exactly where the fractions are equal
    times60 = [j / 60 for j in range(120)]
    first = {round(t, 9): pins_at(a, t) for t in times24[::-1]}  # backwards here, forwards below
    for t in times60:
        q = pins_at(b, t)
        if round(t, 9) in first:  # a common time: the same frame, bit for bit
            assert np.array_equal(q, first[round(t, 9)]), t
    common = [t for t in first if abs(t * 60 - round(t * 60)) < 1e-6]
    assert len(common) >= 20
    # the anchor is where the animation puts it, the others lag behind it
    doc = puppet.load_scene(path)
    anim = state_at(doc.tracks(), 0.5).to
    P = pins_at(doc, 0.5)
    assert np.hypot(*(P[0] - anim[0])) < 0.5
    assert np.hypot(*(P[3] - anim[3])) > 5.0


def test_a_stopped_chain_settles_on_its_animated_pose(scene):
    doc = puppet.load_scene(scene(tail_scene({"chains": [CHAIN]}, inbetween="linear")))
    sim = doc.tracks().physics
    settle = 5.0 / (CHAIN["damping"] * 2 * np.pi * CHAIN["frequency"])  # 1.33 s

    def animated(t):  # where the animation has the chain: unkeyed pins carried by the anchor
        return chain_paths(doc.tracks(), sim.cols, sim.parent, np.array([t]))[0]
    swing = max(np.hypot(*(sim.positions(t) - animated(t)).T).max() for t in np.arange(0, STOP, 0.05))
    assert swing > 10.0  # it did swing
    assert np.hypot(*(sim.positions(STOP + settle) - animated(STOP + settle)).T).max() <= 1.0
    np.testing.assert_allclose(animated(STOP + settle), [(20, 10), (80, 10), (140, 10), (200, 10)], atol=1e-9)
    # the energy falls once the anchor stops (sampled at every step, no growth over a period)
    ts = STOP + np.arange(int(settle * RATE)) / RATE
    X = np.array([sim.positions(t) for t in ts])
    kinetic = 0.5 * (np.diff(X, axis=0) * RATE) ** 2
    per = int(RATE / CHAIN["frequency"])
    peaks = [kinetic[i:i + per].sum() for i in range(0, len(kinetic) - per, per)]
    assert all(b < a for a, b in zip(peaks, peaks[1:]))
    # the frames: the meshes' pins are where the simulation has them
    L = doc.layers(time=0.6)[0]
    np.testing.assert_allclose(L.deformed[L.pins["t3"]], sim.positions(0.6)[3], atol=0.5)


def test_gravity_hangs_a_chain_and_rigid_inbetweens_solve_its_group(scene):
    doc = puppet.load_scene(scene(tail_scene({"chains": [dict(CHAIN, gravity=3000.0, frequency=0.5, damping=1.0)]})))
    P = pins_at(doc, 3.9)
    assert P[3, 1] > P[0, 1] + 40  # the free end hangs below its anchor
    lengths = np.hypot(*np.diff(doc.tracks().physics.positions(3.9), axis=0).T)
    np.testing.assert_allclose(lengths, 60.0, atol=1e-6)  # links keep their animated lengths


def test_paths_agree_with_the_tracks(scene):
    doc = puppet.load_scene(scene(tail_scene()))
    tr = doc.tracks()
    times = np.linspace(-0.1, 4.5, 97)
    paths = pin_paths(tr, np.arange(4), times)
    for t, p in zip(times, paths):
        np.testing.assert_allclose(p, state_at(tr, max(t, 0.0)).to, atol=1e-9)


def test_without_physics_frames_are_as_before_and_bad_chains_are_refused(scene, make_scene):
    plain = puppet.load_scene(scene(tail_scene()))
    assert plain.tracks().physics is None and plain.not_applied() == []
    still = tail_scene({"chains": [CHAIN]})
    del still["animation"]
    assert puppet.load_scene(scene(still)).not_applied() == [
        "physics chains swing in an animation only, and the scene has none"]
    with_chain = puppet.load_scene(scene(tail_scene({"chains": [{"pins": ["t1", "t2"]}]})))
    # t0 is no chain's: before t1 moves nothing differs at t = 0
    assert np.array_equal(plain.layers(time=0.0)[0].deformed, with_chain.layers(time=0.0)[0].deformed)
    bad = [({"chains": [{"pins": ["t0"]}]}, r"physics\.chains\[0\]\.pins", "at least 2"),
           ({"chains": [{"pins": ["t0", "nope"]}]}, r"physics\.chains\[0\]\.pins\[1\]", "no pin named"),
           ({"chains": [{"pins": ["t0", "t1"]}, {"pins": ["t1", "t2"]}]}, r"physics\.chains\[1\]\.pins\[0\]",
            "in a chain already"),
           ({"chains": [dict(CHAIN, frequency=0)]}, r"physics\.chains\[0\]\.frequency", ""),
           ({"chains": [dict(CHAIN, damping=-1)]}, r"physics\.chains\[0\]\.damping", ""),
           ({"chains": [dict(CHAIN, spring=1)]}, r"physics\.chains\[0\]", "spring"),
           ({"chain": []}, r"physics", "chains")]
    for physics, where, words in bad:
        with pytest.raises(SceneError, match=where) as e:
            puppet.load_scene(scene(tail_scene(physics)))
        assert words in str(e.value)


def test_chains_follow_renamed_and_removed_pins(scene, tmp_path):
    doc = puppet.load_scene(scene(tail_scene({"chains": [CHAIN]})))
    before = pins_at(doc, 0.7)
    assert doc.rename_pin("t3", "tip")
    assert doc.to_dict()["physics"]["chains"][0]["pins"] == ["t0", "t1", "t2", "tip"]
    assert np.array_equal(pins_at_named(doc, 0.7, ["t0", "t1", "t2", "tip"]), before)
    assert doc.remove_pin("t1")
    assert doc.to_dict()["physics"]["chains"][0]["pins"] == ["t0", "t2", "tip"]
    assert doc.remove_pin("t0") and doc.remove_pin("t2")  # a chain left with one pin is dropped
    assert doc.to_dict()["physics"]["chains"] == []
    doc.undo()
    assert doc.to_dict()["physics"]["chains"][0]["pins"] == ["t2", "tip"]


def pins_at_named(doc, t, names) -> np.ndarray:
    L = doc.layers(time=t)[0]
    return np.array([L.deformed[L.pins[n]] for n in names])
