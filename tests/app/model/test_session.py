"""The scene session without a window: its intents run on the scene thread and publish
snapshots whose layers are exactly what the scene solves (``scene.layers``)."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from puppet.app.model.session import SceneSession
from puppet.scene.drag.session import base_pose, pose_with
from tests.conftest import bar_image, bar_scene


@pytest.fixture
def session(make_scene):
    """A session with the bar scene open (pins left, mid, right; pose 'bend'; keys at 0 s
    (rest) and 1 s (bend))."""
    doc = bar_scene()
    doc["pins"].insert(1, {"name": "mid", "layer": "bar", "at": [60, 20]})
    path = make_scene(doc, {"bar.png": bar_image()})
    s = SceneSession()
    s.open(path, picture=False)
    wait(s)
    yield s
    s.stop()


def wait(s: SceneSession) -> None:
    assert s.wait_idle(120), "the scene thread did not finish"


def same(a, b) -> bool:
    """Two lists of LayerResults are the same solve, bit for bit."""
    return len(a) == len(b) and all(
        x.name == y.name and np.array_equal(x.deformed, y.deformed) and np.array_equal(x.depth, y.depth)
        for x, y in zip(a, b))


def at_time(scene, t: float, pin: str) -> list[float]:
    """Where the animation puts ``pin`` at time ``t`` (whatever form its key has)."""
    i = [p.name for p in scene.data.pins].index(pin)
    return [float(v) for v in scene.state(time=t).to[i]]


def errors(s) -> list[str]:
    return [m.text for m in s.messages if m.level == "error"]


def test_open_publishes_the_scene(session):
    snap = session.latest
    assert snap.loaded and snap.file == session.scene.file and not snap.dirty and not snap.preview
    assert snap.active == "rest" and snap.poses == ("rest", "bend")
    assert same(snap.layers, session.scene.layers())
    assert any("opened scene.json" in m.text for m in session.messages)


def test_show_rest_time_and_onion(session):
    s = session.scene
    session.edit(lambda sc: sc.set_active_pose("bend"))
    session.show(rest=True)
    wait(session)
    assert session.latest.shown == "rest" and same(session.latest.layers, s.layers("rest"))
    session.show(rest=False, time=0.5)
    wait(session)
    snap = session.latest
    assert snap.time == 0.5 and snap.shown == "0.50 s" and same(snap.layers, s.layers(time=0.5))
    assert not same(snap.layers, s.layers("bend"))
    session.show(onion={"mode": "keys", "count": 1, "opacity": 0.4})
    wait(session)
    ghosts = session.latest.ghosts
    assert [(g[0], g[1]) for g in ghosts] == [("before", 1.0), ("after", 1.0)]
    assert same(ghosts[0][2], s.layers(time=0.0)) and same(ghosts[1][2], s.layers(time=1.0))
    session.show(time=None)
    wait(session)
    assert session.latest.time is None and same(session.latest.layers, s.layers("bend"))


@pytest.mark.parametrize("names", [["right"], ["left", "mid", "right"]])
def test_pose_drag_previews_and_releases_the_exact_pose(session, names):
    s = session.scene
    session.edit(lambda sc: sc.set_active_pose("bend"))
    wait(session)
    start = base_pose(s)
    undo = len(s.history.undo_stack)
    session.begin_drag(names)
    for k in range(1, 4):
        session.move_drag({n: (10.0 + 40 * i + k, 10.0 - k) for i, n in enumerate(names)})
        wait(session)
        assert session.latest.preview
    final = {n: (12.0 + 40 * i, 4.0) for i, n in enumerate(names)}
    session.end_drag(final)
    wait(session)
    snap = session.latest
    assert not snap.preview and not errors(session)
    assert same(snap.layers, s.layers(pose_with(start, final)))  # exactly what render(pose=...) draws
    assert len(s.history.undo_stack) == undo + 1  # one undo step
    pose = s.to_dict()["poses"]["bend"]
    assert all(pose[n] == list(final[n]) for n in names)


def test_drag_at_rest_makes_a_pose_and_a_click_makes_none(session):
    s = session.scene
    session.begin_drag(["right"])
    session.end_drag(None)  # pressed, never moved
    wait(session)
    assert s.active_pose == "rest" and list(s.data.poses) == ["bend"]
    session.begin_drag(["right"])
    session.move_drag({"right": (100.0, 30.0)})
    session.end_drag({"right": (100.0, 35.0)})
    wait(session)
    assert s.active_pose not in ("rest", "bend") and session.latest.active == s.active_pose
    assert same(session.latest.layers, s.layers({"right": [100.0, 35.0]}))


def test_key_drag_keys_the_pins_at_the_time(session):
    s = session.scene
    session.show(time=0.5)
    session.begin_drag(["mid", "right"], time=0.5)
    session.move_drag({"mid": (60.0, 25.0), "right": (104.0, 30.0)})
    session.end_drag({"mid": (60.0, 28.0), "right": (104.0, 33.0)})
    wait(session)
    assert 0.5 in [k["time"] for k in s.keys()]
    assert at_time(s, 0.5, "mid") == [60.0, 28.0] and at_time(s, 0.5, "right") == [104.0, 33.0]
    snap = session.latest
    assert snap.time == 0.5 and not snap.preview and same(snap.layers, s.layers(time=0.5))


def test_record_moves_in_time_and_commits_its_keys(session):
    s = session.scene
    session.show(time=0.0)
    session.begin_drag(["right"], time=0.0, record=True)
    for t in (0.1, 0.2, 0.3):
        session.move_drag({"right": (105.0, 20.0 + 30 * t)}, time=t)
        wait(session)
        assert session.latest.preview
    keys = {0.0: {"right": [105.0, 20.0]}, 0.3: {"right": [105.0, 29.0]}}
    session.end_drag(keys=keys, message="recorded right")
    wait(session)
    assert session.messages[-1].text == "recorded right"
    assert 0.3 in [k["time"] for k in s.keys()] and at_time(s, 0.3, "right") == [105.0, 29.0]
    assert same(session.latest.layers, s.layers(time=0.0))


def test_pointer_moves_coalesce(session):
    """Moves posted while the scene thread is busy run once: only the newest."""
    gate = threading.Event()
    session.edit(lambda sc: gate.wait(10))
    session.begin_drag(["right"])
    v0 = session.latest.version
    for k in range(20):
        session.move_drag({"right": (100.0, 20.0 + k)})
    gate.set()
    wait(session)
    assert session.latest.version == v0 + 2  # the blocking edit's snapshot and one preview
    session.end_drag({"right": (100.0, 39.0)})
    wait(session)


def test_errors_become_messages_and_the_thread_lives(session):
    session.edit(lambda sc: sc.set_active_pose("nope"))
    session.edit(lambda sc: 1 / 0)
    session.edit(lambda sc: "done")
    wait(session)
    texts = [m.text for m in session.messages]
    assert any("no pose named 'nope'" in t for t in texts)
    assert any(t.startswith("internal error: ZeroDivisionError") for t in texts)
    assert texts[-1] == "done"


def test_save_after_and_a_copy(session, tmp_path):
    saved = []
    session.after(saved.append)
    session.edit(lambda sc: sc.set_target("right", (100, 10), pose="bend"))
    session.after(saved.append)
    target = str(tmp_path / "out" / "copy.json")
    (tmp_path / "out").mkdir()
    session.save(target)
    session.after(saved.append)
    copies = []
    session.write_copy(str(tmp_path), copies.append)
    wait(session)
    assert saved == [True, False, True] and session.scene.file == target and not session.latest.dirty
    import puppet

    assert puppet.load_scene(target).to_dict() == session.scene.to_dict()
    assert copies == [str(tmp_path / "scene.json")]


def test_prefetch_solves_frames_once_per_state(session):
    times = [0.0, 0.1, 0.2, 0.3]
    session.prefetch(times)
    wait(session)
    assert session.cached_frames() == 4
    session.edit(lambda sc: sc.set_target("right", (100, 10), pose="bend"))
    wait(session)
    assert session.cached_frames() == 0  # a new scene state: its frames are solved anew


def test_close_scene(session):
    session.close_scene()
    wait(session)
    assert session.scene is None and not session.latest.loaded
    session.edit(lambda sc: None)
    wait(session)
    assert errors(session)[-1] == "no scene is open"


def _child_heard(session, timeout: float = 120.0) -> None:
    """Wait until the session's solver process has said something (it is ready for a drag:
    the second follows at once, its scene built), then a second more; a fixed 3 s sleep was
    too short for a fresh python under load (the child served no drag)."""
    end = time.monotonic() + timeout
    while not session._proc.conn.poll(0.05) and time.monotonic() < end:
        pass
    time.sleep(1.0)


@pytest.mark.slow
def test_a_solver_process_gives_the_thread_s_previews_and_release(make_scene):
    """Previews solved in the session's child process are the scene thread's, bit for bit,
    and the release is the exact pose; the child stops with the session."""
    doc = bar_scene()
    path = make_scene(doc, {"bar.png": bar_image()})
    runs = {}
    for solver in ("thread", "process"):
        s = SceneSession(solver=solver)
        try:
            s.open(path, picture=False)
            s.edit(lambda sc: sc.set_active_pose("bend"))
            wait(s)
            previews = []
            for k in range(2):  # the second drag is served by the child once it has started
                s.begin_drag(["right"])
                wait(s)
                if k and solver == "process":  # the child starts (a fresh python) and builds the scene meanwhile
                    _child_heard(s)
                for k in range(1, 4):
                    s.move_drag({"right": (100.0 - 3 * k, 5.0 + 4 * k)})
                    wait(s)
                    previews.append(s.latest.layers)
                s.end_drag({"right": (90.0, 20.0)})
                wait(s)
            assert not errors(s) and same(s.latest.layers, s.scene.layers("bend"))
            runs[solver] = previews, s._proc
        finally:
            s.stop()
    child = runs["process"][1]
    assert runs["thread"][1] is None and child is not None and not child.alive  # the child stopped
    assert child.ready >= 2  # and it had served the second drag
    assert all(same(a, b) for a, b in zip(runs["thread"][0], runs["process"][0]))


def test_an_idle_scene_thread_builds_the_reduced_models_a_first_drag_frame_needs(make_scene, monkeypatch):
    """While nothing is asked, the scene thread builds the reduced models of the big groups
    once per built version; the first preview of a drag then builds none."""
    from puppet.scene.rig import reduced

    monkeypatch.setattr(reduced, "REDUCED_MIN", 50)  # the bar's group counts as big
    doc = bar_scene()
    path = make_scene(doc, {"bar.png": bar_image()})
    s = SceneSession()
    try:
        s.open(path, picture=False)
        wait(s)
        memo = s.scene.rig.memo
        assert len(s.scene.built.groups[0].mesh.V) > 50
        built = memo.count("reduced model")
        assert built == 1
        s.begin_drag(["left"])
        s.move_drag({"left": (12.0, 30.0)})
        wait(s)
        assert memo.count("reduced model") == built  # found, not built again
        s.end_drag()
        wait(s)
    finally:
        s.stop()
