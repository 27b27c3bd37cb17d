"""The drag session (no GL): every kind of drag releases exactly the layers that
``layers(pose=...)`` / ``layers(time=...)`` give, in one undo step; previews are
warm-started (no factorisation, no exact solve per move) and follow the pins."""
from __future__ import annotations

import numpy as np
import pytest

from puppet.deform import factor
from puppet.errors import SceneError
from puppet.scene.document.core import Document
from puppet.scene.drag.session import base_pose, pose_with
from tests.conftest import SCENES


@pytest.fixture
def trex():
    return Document.load(SCENES + "/trex-layers.json")


@pytest.fixture
def dress():
    return Document.load(SCENES + "/dress-garment.json")


def same_layers(a, b):
    assert [r.name for r in a] == [r.name for r in b]
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.deformed, y.deformed)
        np.testing.assert_array_equal(x.depth, y.depth)
        assert x.exterior == y.exterior


def path(start, n=6, step=(6.0, -4.0)):
    return [np.asarray(start, float) + k * np.asarray(step) for k in range(1, n + 1)]


def pin_at(doc, name):
    return next(p.at for p in doc.data.pins if p.name == name)


def test_pose_with_keeps_angle_and_depth():
    pose = {"a": [1, 2], "b": {"to": [3, 4], "angle": 30.0, "depth": 2.0}}
    out = pose_with(pose, {"a": (5, 6), "b": np.array([7.0, 8.0]), "c": (9, 10)})
    assert out == {"a": [5.0, 6.0], "b": {"to": [7.0, 8.0], "angle": 30.0, "depth": 2.0}, "c": [9.0, 10.0]}
    assert pose == {"a": [1, 2], "b": {"to": [3, 4], "angle": 30.0, "depth": 2.0}}  # a copy


def test_one_pin_in_a_pose(trex):
    trex.set_active_pose("wave")
    before, steps = trex.to_dict(), len(trex.history.undo_stack)
    d = trex.drag("hand_front")
    for xy in path((100, 200)):
        d.move_layers(xy)
    got = d.release_layers()
    pose = trex.to_dict()["poses"]["wave"]
    assert pose == pose_with(before["poses"]["wave"], {"hand_front": path((100, 200))[-1]})
    same_layers(got, trex.layers(pose=pose))
    same_layers(got, Document.load(SCENES + "/trex-layers.json").layers(pose=pose))  # path-independent
    assert len(trex.history.undo_stack) == steps + 1
    trex.undo()
    assert trex.to_dict() == before


def test_several_pins_one_step(trex):
    trex.set_active_pose("roar")
    before, steps = trex.to_dict(), len(trex.history.undo_stack)
    names = ["hand_front", "tail_tip", "foot_left"]
    d = trex.drag(names)
    built = trex.built
    idx = [[p.name for p in trex.data.pins].index(n) for n in names]
    groups = {built.group_of_pin(i) for i in idx}
    for k in range(1, 6):
        targets = {n: np.asarray(pin_at(trex, n)) + [4.0 * k, 3.0 * k] for n in names}
        layers = d.move_layers(targets)
        for n, xy in targets.items():  # every moved pin is where it is dragged in the preview
            r = next(r for r in layers if n in r.pins)
            np.testing.assert_allclose(r.deformed[r.pins[n]], xy, atol=1e-9)
    assert set(d._U) == groups
    got = d.release_layers()
    pose = pose_with(before["poses"]["roar"], targets)
    assert trex.to_dict()["poses"]["roar"] == pose
    same_layers(got, trex.layers(pose=pose))
    assert len(trex.history.undo_stack) == steps + 1


def test_moves_are_warm_started(trex):
    trex.set_active_pose("wave")
    d = trex.drag(["hand_front", "jaw"])
    d.move_layers({"hand_front": (110, 190), "jaw": pin_at(trex, "jaw")})  # first frame: the pose's exact solve
    fact, solves = factor.FACTORIZATIONS, trex.rig.memo.count("solve")
    frames = [d.move_layers({"hand_front": (110 + 3 * k, 190 - 2 * k)}) for k in range(1, 6)]
    assert factor.FACTORIZATIONS == fact and trex.rig.memo.count("solve") == solves
    a, b = (next(r for r in f if "hand_front" in r.pins) for f in frames[:2])
    assert not np.array_equal(a.deformed, b.deformed)
    d.cancel()


def keyed_at(doc, t):
    """{pin: (x, y)} where the animation's tracks put every interior pin at ``t``."""
    st = doc.state(time=t)
    return {p.name: tuple(st.to[i]) for i, p in enumerate(doc.data.pins) if p.kind == "interior"}


def test_key_drag_between_keys(trex):
    t = 0.75
    before, steps = trex.to_dict(), len(trex.history.undo_stack)
    others = keyed_at(trex, t)
    d = trex.drag(["hand_front", "snout"], time=t)
    targets = {"hand_front": (120.0, 210.0), "snout": np.asarray(others["snout"]) + [5, -5]}
    for k in range(4):
        d.move_layers({n: np.asarray(xy) - 2 * (3 - k) for n, xy in targets.items()})
    got = d.release_layers()
    same_layers(got, trex.layers(time=t))
    now = keyed_at(trex, t)  # the pins keyed where they were dragged, the others as they were
    assert all(np.allclose(now[n], xy) for n, xy in targets.items())
    assert all(np.allclose(now[n], xy) for n, xy in others.items() if n not in targets)
    assert trex.to_dict()["poses"] == before["poses"]  # a key drag leaves the poses alone
    assert len(trex.history.undo_stack) == steps + 1
    trex.undo()
    assert trex.to_dict() == before


def test_key_drag_on_a_pose_key(trex):
    others = keyed_at(trex, 0.5)
    d = trex.drag("jaw", time=0.5)
    d.move_layers((300.0, 120.0))
    got = d.release_layers()
    same_layers(got, trex.layers(time=0.5))
    now = keyed_at(trex, 0.5)
    assert now["jaw"] == (300.0, 120.0)
    assert all(np.allclose(now[n], xy) for n, xy in others.items() if n != "jaw")


def test_record(trex):
    before, steps = trex.to_dict(), len(trex.history.undo_stack)
    jaw = {t: keyed_at(trex, t)["jaw"] for t in (0.3, 0.5, 0.6)}
    d = trex.drag("tail_tip", time=0.25, record=True)
    start = np.asarray(pin_at(trex, "tail_tip"))
    for k in range(1, 5):
        d.move_layers(start + [3.0 * k, 0.0], time=0.25 + 0.1 * k)
    keys = {0.25: {"tail_tip": start}, 0.45: {"tail_tip": start + [6, 0]}, 0.65: {"tail_tip": start + [12, 0]}}
    got = d.release_layers(keys)
    same_layers(got, trex.layers(time=0.25))
    for t, pins in keys.items():  # the tail follows the recorded keys only, over the span
        np.testing.assert_allclose(keyed_at(trex, t)["tail_tip"], pins["tail_tip"], atol=1e-9)
    np.testing.assert_allclose(keyed_at(trex, 0.5)["tail_tip"], start + [7.5, 0], atol=1e-9)  # not the 0.5 s pose
    assert {t: keyed_at(trex, t)["jaw"] for t in jaw} == jaw  # the other pins keep their keys
    assert len(trex.history.undo_stack) == steps + 1
    trex.undo()
    assert trex.to_dict() == before


def test_exterior_point(dress):
    dress.set_active_pose("flare")
    d = dress.drag(["edge_b", "hem_c"])
    preview = d.move_layers({"edge_b": (250, 515), "hem_c": (250, 480)})
    moved = pose_with(dress.to_dict()["poses"]["flare"], {"edge_b": (250, 515), "hem_c": (250, 480)})
    same_layers(preview, dress.layers(pose=moved))  # an exterior point's group is solved exactly
    got = d.release_layers({})
    pose = dress.to_dict()["poses"]["flare"]
    assert pose["edge_b"] == [250.0, 515.0]
    same_layers(got, dress.layers(pose=pose))


def test_drag_at_rest_makes_a_pose_on_release(trex):
    names = trex.pose_names()
    d = trex.drag("hand_front")
    d.move_layers((120, 230))
    d.cancel()
    assert trex.pose_names() == names and trex.active_pose == "rest"  # a cancelled drag leaves nothing
    d = trex.drag("hand_front")
    d.move_layers((120, 230))
    d.release_layers()
    assert trex.active_pose not in names and trex.active_pose in trex.data.poses
    trex.undo()
    assert trex.active_pose == "rest" and trex.pose_names() == names


def test_a_click_changes_nothing(trex):
    steps = len(trex.history.undo_stack)
    for kw in ({}, {"time": 0.3}, {"time": 0.3, "record": True}):
        trex.drag("jaw", **kw).release_layers()
    assert len(trex.history.undo_stack) == steps


@pytest.mark.parametrize("call, words", [
    (lambda s: s.drag("nobody"), "no pin"),
    (lambda s: s.drag([]), "at least one"),
    (lambda s: s.drag(["jaw", "jaw"]), "twice"),
    (lambda s: s.drag("jaw", record=True), "record mode needs"),
    (lambda s: s.drag("jaw", time=-1.0), "time must be"),
    (lambda s: s.drag("jaw").move_layers((np.nan, 1)), "finite"),
    (lambda s: s.drag(["jaw", "snout"]).move_layers((1, 1)), "give"),
    (lambda s: s.drag("jaw").move_layers({"snout": (1, 1)}), "not one of"),
    (lambda s: s.drag("jaw").move_layers((1, 1), time=0.2), "only a recording"),
])
def test_bad_drags_are_user_errors(trex, call, words):
    with pytest.raises(SceneError, match=words):
        call(trex)


def test_released_drag_refuses_more(trex):
    d = trex.drag("jaw")
    d.release_layers()
    with pytest.raises(SceneError, match="released"):
        d.move_layers((1, 1))
    with pytest.raises(SceneError, match="released"):
        d.commit()


def test_reduced_rgba_averages_premultiplied():
    from puppet.scene.rig.build import reduced_rgba

    a = np.zeros((4, 6, 4), np.uint8)
    a[0, 0] = (255, 0, 0, 255)  # one opaque red texel among three transparent (black) ones
    a[2:4, 0:2] = (10, 200, 30, 128)  # a uniform half-transparent block keeps its colour
    a[0:2, 4:6] = (0, 0, 255, 255)
    a[1, 5] = (255, 255, 255, 0)  # a transparent texel's colour must not bleed in
    r = reduced_rgba(a, 2)
    assert r.shape == (2, 3, 4) and r.dtype == np.uint8
    assert tuple(r[0, 0]) == (255, 0, 0, 64)
    np.testing.assert_allclose(r[1, 0], (10, 200, 30, 128), atol=1)  # 8-bit premultiplied: +-1
    assert tuple(r[0, 2]) == (0, 0, 255, 191)
    assert tuple(r[1, 2]) == (0, 0, 0, 0)
    assert reduced_rgba(a, 4).shape == (1, 2, 4)  # ceil of the odd size


def test_an_edit_during_the_drag_is_followed(trex):
    trex.set_active_pose("wave")
    d = trex.drag("hand_front")
    d.move_layers((120.0, 200.0))
    assert len(trex.events._callbacks) == 1  # the session listens to the document
    trex.set_target("jaw", (330.0, 95.0))  # an edit while dragging (another tool, a script)
    layers = d.move_layers((124.0, 198.0))
    jaw = next(r for r in layers if "jaw" in r.pins)
    np.testing.assert_allclose(jaw.deformed[jaw.pins["jaw"]], (330.0, 95.0), atol=1e-9)
    trex.move_pin("tail_tip", np.asarray(pin_at(trex, "tail_tip")) + [-2.0, 0.0])  # re-meshes a layer
    layers = d.move_layers((126.0, 196.0))
    assert all(r.rest is m.V for r, m in zip(layers, trex.built.meshes))
    got = d.release_layers()
    same_layers(got, trex.layers(pose=trex.to_dict()["poses"]["wave"]))
    assert trex.events._callbacks == []  # and stops listening when it ends


def run_drag(doc, results):
    d = doc.drag(["hand_front", "tail_tip"], time=0.7)
    for k in range(5):
        results.append(d.move_layers({"hand_front": (100.0 + 4 * k, 200.0 - k), "tail_tip": (550.0, 240.0 + 2 * k)}))
    results.append(d.release_layers())


def compare_modes() -> None:
    """A drag run plainly, then on a worker thread while this thread keeps running Python:
    the same numbers bit for bit (run by the test below in a fresh process)."""
    import threading

    plain, threaded = [], []
    run_drag(Document.load(SCENES + "/trex-layers.json"), plain)
    doc = Document.load(SCENES + "/trex-layers.json")
    assert doc.built.pre[0].arap.factor.kind == "qdldl"  # the factoriser that releases the GIL
    worker = threading.Thread(target=run_drag, args=(doc, threaded))
    worker.start()
    busy = 0
    while worker.is_alive():  # the "window": Python work on the main thread meanwhile
        busy += sum(i * i for i in range(1000)) > 0
    worker.join()
    assert busy > 0 and len(threaded) == len(plain) == 6
    for a, b in zip(plain, threaded):
        same_layers(a, b)


@pytest.mark.slow
def test_a_drag_on_the_scene_thread_gives_the_same_numbers():
    """The chosen mode: the solver on the scene thread (its factor releases the GIL).
    Run as the ``puppet`` command runs, one BLAS thread from the start (a BLAS product
    split over two threads sums in another order: 1e-13 apart)."""
    import os
    import subprocess
    import sys

    from tests.conftest import ROOT as root

    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PUPPET_BLAS_SET_AT_START="1", PYTHONPATH=root)
    r = subprocess.run([sys.executable, "-c", "from tests.scene.drag.test_session import compare_modes; "
                        "compare_modes()"], cwd=root, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]


def test_a_big_group_is_previewed_on_its_reduced_model(monkeypatch):
    from puppet.scene.rig import reduced

    monkeypatch.setattr(reduced, "REDUCED_MIN", 500)  # the horse's one group counts as big
    monkeypatch.setattr(reduced, "REDUCED_VERTICES", 300)
    doc = Document.load(SCENES + "/horse.json")
    fine = doc.built.meshes[0]
    assert len(fine.V) > 500
    d = doc.drag(["head", "tail"])
    targets = {"head": np.asarray(pin_at(doc, "head")), "tail": np.asarray(pin_at(doc, "tail"))}
    for k in range(1, 5):
        targets = {"head": targets["head"] + [3.0, -2.0], "tail": targets["tail"] + [-2.0, 1.0]}
        (r,) = d.move_layers(targets)
        assert len(r.rest) < 0.8 * len(fine.V) and len(r.triangles) < 0.8 * len(fine.F)  # the coarse mesh
        for n, xy in targets.items():
            np.testing.assert_allclose(r.deformed[r.pins[n]], xy, atol=1e-9)
        assert r.deformed.shape == r.rest.shape and r.depth.shape == (len(r.rest),)
        assert set(r.pins) == {p.name for p in doc.data.pins}
    # the coarse shape follows the fine solve: each coarse vertex against the nearest fine one
    exact = doc.layers(pose=pose_with(base_pose(doc), targets))[0]
    near = np.argmin(((r.rest[:, None] - exact.rest[None]) ** 2).sum(-1), axis=1)
    off = np.linalg.norm((r.deformed - r.rest) - (exact.deformed - exact.rest)[near], axis=1)
    moved = np.linalg.norm(exact.deformed - exact.rest, axis=1).max()
    assert moved > 10 and np.median(off) < 1.0 and off.max() < 4.0
    assert d._U == {} and set(d._detail) == {0}
    got = d.release_layers()
    assert got[0].rest is fine.V  # the release is the fine mesh, exactly
    same_layers(got, doc.layers(pose=doc.to_dict()["poses"][doc.active_pose]))


@pytest.mark.parametrize("mode", ["similar", "distort"])
def test_a_big_group_in_another_mode_is_previewed_in_that_mode(monkeypatch, mode):
    from puppet.scene.rig import reduced

    monkeypatch.setattr(reduced, "REDUCED_MIN", 500)  # the horse's one group counts as big
    monkeypatch.setattr(reduced, "REDUCED_VERTICES", 300)
    doc = Document.load(SCENES + "/horse.json")
    doc.set_layer(doc.data.layers[0].name, deformer={"mode": mode})
    fine = doc.built.meshes[0]
    d = doc.drag(["head"])
    (r,) = d.move_layers({"head": np.asarray(pin_at(doc, "head")) + [6.0, -4.0]})
    assert len(r.rest) < len(fine.V)
    model = reduced.reduced_for(doc.rig, doc.built, 0)
    assert model.pre.arap.mix is not None  # the coarse cells are in the layer's mode
    d.cancel()


@pytest.fixture(scope="module")
def solver_process():
    from puppet.scene.drag.process import DragProcess

    proc = DragProcess()
    yield proc
    proc.close()
    assert proc.proc is None


def full_layers(a, b):
    same_layers(a, b)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.rest, y.rest)
        np.testing.assert_array_equal(x.triangles, y.triangles)
        assert x.pins == y.pins and x.order == y.order and x.key == y.key


@pytest.mark.parametrize("names, kw", [
    ("hand_front", {}),
    (["hand_front", "tail_tip", "jaw"], {}),
    (["hand_front", "snout"], {"time": 0.7}),
    ("tail_tip", {"time": 0.2, "record": True}),
])
def test_the_solver_process_gives_the_same_numbers(solver_process, names, kw):
    plain, there = Document.load(SCENES + "/trex-layers.json"), Document.load(SCENES + "/trex-layers.json")
    for doc in (plain, there):
        doc.set_active_pose("wave")
    a = plain.drag(names, **kw)
    b = there.drag(names, **kw, solver=solver_process)
    assert solver_process.wait_ready(b._serial, timeout=120)
    one = [names] if isinstance(names, str) else names
    for k in range(5):
        targets = {n: np.asarray(pin_at(plain, n)) + [3.0 * k + i, -2.0 * k] for i, n in enumerate(one)}
        t = {"time": 0.2 + 0.05 * k} if kw.get("record") else {}
        full_layers(a.move_layers(targets, **t), b.move_layers(targets, **t))
        if k == 2:  # an edit during the drag: the child is given the new document
            for doc in (plain, there):
                doc.set_target("foot_left", (215.0, 450.0))
            assert solver_process.wait_ready(b._serial, timeout=120)
    assert b._U == {}  # every frame came from the child
    keys = {0.2: {one[0]: (500.0, 250.0)}, 0.5: {one[0]: (520.0, 250.0)}} if kw.get("record") else None
    full_layers(a.release_layers(keys), b.release_layers(keys))
    assert plain.to_dict() == there.to_dict()


def test_without_its_process_a_drag_solves_itself(trex):
    from puppet.scene.drag.process import DragProcess

    proc = DragProcess()
    proc.close()
    assert not proc.alive
    d = trex.drag("jaw", solver=proc)
    assert d._serial is None
    d.move_layers((330.0, 100.0))
    assert d._U  # solved here
    d.cancel()


def test_key_pins(trex):
    steps = len(trex.history.undo_stack)
    others = keyed_at(trex, 0.5)
    assert trex.key_pins(0.5, {"jaw": [300.0, 100.0]})  # at the pose key at 0.5 s
    now = keyed_at(trex, 0.5)
    assert now["jaw"] == (300.0, 100.0) and all(now[n] == xy for n, xy in others.items() if n != "jaw")
    assert len(trex.history.undo_stack) == steps + 1


def test_a_solver_process_that_dies_mid_drag(trex):
    from puppet.scene.drag.process import DragProcess

    proc = DragProcess()
    try:
        trex.set_active_pose("wave")
        d = trex.drag("hand_front", solver=proc)
        assert proc.wait_ready(d._serial, timeout=120)
        d.move_layers((120.0, 200.0))
        assert not d._U  # solved there
        proc.proc.kill()
        proc.proc.wait()
        layers = d.move_layers((124.0, 198.0))  # solved here from now on
        assert d._U
        r = next(r for r in layers if "hand_front" in r.pins)
        np.testing.assert_allclose(r.deformed[r.pins["hand_front"]], (124.0, 198.0), atol=1e-9)
        trex.set_target("jaw", (330.0, 95.0))  # an edit: the session must not fail re-opening it there
        d.move_layers((126.0, 196.0))
        same_layers(d.release_layers(), trex.layers(pose=trex.to_dict()["poses"]["wave"]))
    finally:
        proc.close()
