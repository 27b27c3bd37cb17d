"""Animation keys: the file forms, eases, per-pin tracks, depth, key edits with undo,
save and load, and the rigid in-between of a 180-degree arm swing."""
import json
import os

import numpy as np
import pytest
from PIL import Image

import puppet
from puppet.errors import SceneError
from puppet.scene.time.timeline import bezier_ease, ease
from tests.conftest import bar_image, bar_scene

LEFT, RIGHT = np.array([15.0, 20.0]), np.array([105.0, 20.0])


def keyed(make_scene, keys, **anim):
    s = bar_scene()
    s["animation"] = {"fps": 10, "keys": keys, **anim}
    return puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))


# eases ------------------------------------------------------------------------------
def test_bezier_hand_checked():
    # control points on the diagonal: y = x
    for x in (0.1, 0.5, 0.77):
        assert bezier_ease((0, 0, 1, 1), x) == pytest.approx(x, abs=1e-12)
    # (0.5, 0, 0.5, 1): x(s) = 1.5 s (1 - s) + s^3, y(s) = 3 s^2 - 2 s^3; s = 1/4 and 1/2
    assert bezier_ease((0.5, 0, 0.5, 1), 0.296875) == pytest.approx(0.15625, abs=1e-12)
    assert bezier_ease((0.5, 0, 0.5, 1), 0.5) == pytest.approx(0.5, abs=1e-12)
    # overshoot (0.3, 2, 0.7, 2): at s = 1/2, x = 1/2 and y = 1.625
    assert ease("bezier", 0.5, (0.3, 2, 0.7, 2)) == pytest.approx(1.625, abs=1e-12)
    assert ease("bezier", 0.0, (0.3, 2, 0.7, 2)) == 0.0 and ease("bezier", 1.0, (0.3, 2, 0.7, 2)) == 1.0
    with pytest.raises(ValueError):
        ease("bezier", 0.5)


# the file forms ---------------------------------------------------------------------
def test_v1_keys_load_unchanged(bar):
    sc = puppet.load_scene(bar)
    an = sc.data.animation
    assert [(k.time, k.pose, k.ease, k.pins) for k in an.keys] == [(0, "rest", "linear", None),
                                                                   (1, "bend", "linear", None)]
    assert an.inbetween == "rigid" and an.depth == "step" and an.fps == 10
    assert sc.keys() == [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "bend"}]


@pytest.mark.parametrize("key,path,words", [
    ({"time": 1}, "animation.keys[1]", "exactly one of 'pose'"),
    ({"time": 1, "pose": "bend", "pins": {}}, "animation.keys[1]", "exactly one of 'pose'"),
    ({"time": 1, "pins": {"nope": [1, 2]}}, "animation.keys[1].pins.nope", "no pin named"),
    ({"time": 1, "pins": {"right": {"to": [1, 2], "spin": 3}}}, "animation.keys[1].pins.right.spin", "unknown key"),
    ({"time": 1, "pose": "bend", "ease": "bezier"}, "animation.keys[1].curve", "needs 'curve'"),
    ({"time": 1, "pose": "bend", "curve": [0, 0, 1, 1]}, "animation.keys[1].curve", "belongs to the 'bezier'"),
    ({"time": 1, "pose": "bend", "ease": "bezier", "curve": [1.5, 0, 1, 1]}, "animation.keys[1].curve[0]", "<= 1"),
    ({"time": 1, "pose": "bend", "ease": "bezier", "curve": [0, 0, 1]}, "animation.keys[1].curve", "4 items"),
])
def test_bad_keys_name_their_path(make_scene, key, path, words):
    with pytest.raises(SceneError) as e:
        keyed(make_scene, [{"time": 0, "pose": "rest"}, key])
    assert e.value.path == path and words in str(e.value)


@pytest.mark.parametrize("field,value", [("inbetween", "curvy"), ("depth", "smooth")])
def test_bad_modes(make_scene, field, value):
    with pytest.raises(SceneError) as e:
        keyed(make_scene, [{"time": 0, "pose": "rest"}], **{field: value})
    assert e.value.path == f"animation.{field}"


# per-pin tracks ---------------------------------------------------------------------
def test_per_pin_tracks_hold_and_interpolate(make_scene):
    sc = keyed(make_scene, [{"time": 0, "pose": "rest"},
                            {"time": 1, "pins": {"right": [100, 4]}},
                            {"time": 2, "pins": {"left": [19, 28]}, "ease": "smooth"},
                            {"time": 4, "pins": {"right": [110, 30]}, "ease": "step"}])
    pins = lambda t: sc.state(time=t).to  # noqa: E731  (scene pin order: left, right)
    # right: keys at 0 (rest), 1, 4; left: keys at 0 (rest), 2
    smooth = lambda u: u * u * (3 - 2 * u)  # noqa: E731
    assert np.allclose(pins(0.5), [LEFT + smooth(0.25) * ([19, 28] - LEFT), (RIGHT + [100, 4]) / 2])
    assert np.allclose(pins(1.0), [LEFT + 0.5 * ([19, 28] - LEFT), [100, 4]])  # smooth(1/2) = 1/2
    assert np.allclose(pins(3.0), [[19, 28], [100, 4]])  # left holds after its last key; right steps at 4
    assert np.allclose(pins(3.99)[1], [100, 4]) and np.allclose(pins(4.0)[1], [110, 30])
    assert np.allclose(pins(9.0), [[19, 28], [110, 30]])
    assert sc.key_times() == [0, 1, 2, 4]
    assert sc.key_times("right") == [0, 1, 4] and sc.key_times("left") == [0, 2]
    with pytest.raises(SceneError):
        sc.key_times("nope")


def test_bezier_key_and_angle_tracks(make_scene):
    sc = keyed(make_scene, [{"time": 0, "pins": {"right": {"to": [105, 20], "angle": 0}}},
                            {"time": 2, "pins": {"right": {"to": [105, 40], "angle": 30}}, "ease": "bezier",
                             "curve": [0.5, 0, 0.5, 1]}])
    s = sc.state(time=2 * 0.296875)
    assert np.allclose(s.to[1], [105, 20 + 20 * 0.15625]) and s.angle[1] == pytest.approx(30 * 0.15625)


@pytest.mark.parametrize("mode,mid", [("step", 0.0), ("interpolate", 1.5)])
def test_depth_steps_or_interpolates(make_scene, mode, mid):
    sc = keyed(make_scene, [{"time": 0, "pose": "rest"},
                            {"time": 2, "pins": {"right": {"to": [105, 20], "depth": 3}}}], depth=mode)
    assert sc.state(time=1.0).depth[1] == pytest.approx(mid)
    assert sc.state(time=2.0).depth[1] == 3.0 and sc.state(time=0).depth[1] == 0.0
    (r,) = sc.layers(time=1.0)  # and the frame's depth field follows it
    assert r.depth[r.pins["right"]] == pytest.approx(mid, abs=1e-6)


# edits: undo, redo, events ----------------------------------------------------------
EDITS = [
    ("set_key pose", lambda d: d.set_key(2.0, "bend", ease="smooth")),
    ("set_key pins", lambda d: d.set_key(0.5, pins={"right": [90, 10], "left": {"to": [15, 20], "angle": 5}})),
    ("set_key replace", lambda d: d.set_key(1.0, pins={"right": [90, 10]}, ease="bezier", curve=[0.2, 0, 0.8, 1])),
    ("remove_key", lambda d: d.remove_key(1.0)),
    ("move_key", lambda d: d.move_key(1.0, 1.5)),
    ("copy_key", lambda d: d.copy_key(1.0, 3.0)),
    ("set_key_ease", lambda d: d.set_key_ease(1.0, "bezier", [0.1, 0.2, 0.3, 1.4])),
    ("set_fps", lambda d: d.set_fps(30)),
    ("set_inbetween", lambda d: d.set_inbetween("linear")),
    ("set_depth_mode", lambda d: d.set_depth_mode("interpolate")),
]


@pytest.mark.parametrize("name,edit", EDITS, ids=[e[0] for e in EDITS])
def test_key_edits_undo_redo_one_event(bar, name, edit):
    sc = puppet.load_scene(bar)
    events = []
    sc.events.connect(events.append)
    before = sc.to_dict()
    assert edit(sc) is True
    after = sc.to_dict()
    assert after != before and len(events) == 1 and events[0].type == "animation"
    sc.undo()
    assert sc.to_dict() == before
    sc.redo()
    assert sc.to_dict() == after


def test_edits_that_change_nothing_record_nothing(bar):
    sc = puppet.load_scene(bar)
    events = []
    sc.events.connect(events.append)
    for edit in (lambda: sc.set_key(1.0, "bend"), lambda: sc.move_key(1.0, 1.0), lambda: sc.copy_key(1.0, 1.0),
                 lambda: sc.set_key_ease(1.0, "linear"), lambda: sc.set_fps(10), lambda: sc.set_inbetween("rigid"),
                 lambda: sc.set_depth_mode("step")):
        assert edit() is False
    assert events == [] and not sc.history.can_undo()


def test_key_edit_results(bar):
    sc = puppet.load_scene(bar)
    sc.move_key(1.0, 1.5)
    assert sc.keys() == [{"time": 0, "pose": "rest"}, {"time": 1.5, "pose": "bend"}]
    sc.copy_key(1.5, 0.0)  # replaces the key at 0
    assert sc.keys() == [{"time": 0.0, "pose": "bend"}, {"time": 1.5, "pose": "bend"}]
    sc.set_key_ease(1.5, "bezier", (0.25, 0.1, 0.25, 1))
    assert sc.keys()[1] == {"time": 1.5, "pose": "bend", "ease": "bezier", "curve": [0.25, 0.1, 0.25, 1.0]}
    sc.set_key_ease(1.5, "linear")
    assert sc.keys()[1] == {"time": 1.5, "pose": "bend"}
    assert sc.duration() == 1.5
    sc.remove_key(0.0)
    sc.remove_key(1.5)
    assert sc.keys() == [] and sc.duration() == 0.0 and sc.data.animation is None


@pytest.mark.parametrize("call,words", [
    (lambda d: d.set_key(1.0), "one of pose= and pins="),
    (lambda d: d.set_key(1.0, "bend", pins={}), "one of pose= and pins="),
    (lambda d: d.set_key(1.0, "bend", ease="bezier"), "curve"),
    (lambda d: d.set_key(1.0, "bend", ease="wobbly"), "not an ease"),
    (lambda d: d.set_key(1.0, "nope"), "no pose named"),
    (lambda d: d.set_key(1.0, pins={"nope": [1, 2]}), "no pin named"),
    (lambda d: d.remove_key(0.5), "no animation key at 0.5"),
    (lambda d: d.move_key(0.5, 1), "no animation key"),
    (lambda d: d.set_inbetween("curvy"), "not an in-between"),
    (lambda d: d.set_depth_mode("smooth"), "not a depth mode"),
    (lambda d: d.set_fps(0), "fps"),
])
def test_bad_key_edits_change_nothing(bar, call, words):
    sc = puppet.load_scene(bar)
    before = sc.to_dict()
    with pytest.raises(SceneError) as e:
        call(sc)
    assert words in str(e.value) and sc.to_dict() == before and not sc.history.can_undo()


def test_pin_edits_follow_into_keys(bar):
    sc = puppet.load_scene(bar)
    sc.set_key(2.0, pins={"right": [90, 10], "left": [16, 20]})
    sc.rename_pin("right", "tip")
    assert sc.keys()[-1]["pins"] == {"tip": [90.0, 10.0], "left": [16.0, 20.0]}
    sc.remove_pin("left")
    assert sc.keys()[-1]["pins"] == {"tip": [90.0, 10.0]}


def test_save_load_keeps_keys_and_frames(bar, tmp_path):
    sc = puppet.load_scene(bar)
    sc.set_key(0.5, pins={"right": {"to": [95, 12], "angle": 10, "depth": 1.5}}, ease="bezier", curve=[0.3, 0, 0.6, 1])
    sc.set_key(2.0, pins={"left": [18, 25]}, ease="step")
    sc.set_depth_mode("interpolate")
    sc.set_inbetween("linear")
    sc.save(str(tmp_path / "saved.json"))
    again = puppet.load_scene(str(tmp_path / "saved.json"))
    a, b = again.data.animation, sc.data.animation
    assert again.keys() == sc.keys() and (a.fps, a.inbetween, a.depth) == (b.fps, b.inbetween, b.depth)
    assert [(k.time, k.ease, k.curve, sorted(k.pins or {})) for k in a.keys] == \
        [(k.time, k.ease, k.curve, sorted(k.pins or {})) for k in b.keys]
    for t in (0.25, 0.7, 1.5, 2.5):
        assert np.array_equal(again.layers(time=t)[0].deformed, sc.layers(time=t)[0].deformed)


def test_pose_at_reproduces_the_frame(bar):
    sc = puppet.load_scene(bar)
    for mode in ("linear", "rigid"):
        sc.set_inbetween(mode)
        frame = sc.layers(time=0.4)[0]
        pins = sc.pose_at(0.4)
        assert set(pins) == {"left", "right"}
        assert np.allclose(pins["right"], frame.deformed[frame.pins["right"]])
        sc.set_key(0.4, pins=pins)
        assert np.allclose(sc.layers(time=0.4)[0].deformed, frame.deformed, atol=0.5)
        sc.undo()


# rigid in-betweens ------------------------------------------------------------------
def arm_scene(folder) -> str:
    """A 12 x 80 px arm in front of a body, swung 180 degrees up about the shoulder."""
    im = np.zeros((200, 120, 4), np.uint8)
    im[100:190, 10:50] = (70, 110, 200, 255)
    im[100:180, 56:68] = (200, 120, 90, 255)
    Image.fromarray(im).save(os.path.join(folder, "arm.png"))
    s = {"puppet": 1, "canvas": [120, 200], "source": "arm.png",
         "layers": [{"name": "body", "mask": {"rect": [8, 98, 44, 94]}},
                    {"name": "arm", "mask": {"rect": [54, 98, 16, 84]}, "mesh": {"max_area": 6}}],
         "pins": [{"name": "hip", "layer": "body", "at": [30, 170]},
                  {"name": "shoulder", "layer": "arm", "at": [62, 105]},
                  {"name": "hand", "layer": "arm", "at": [62, 175]}],
         "poses": {"up": {"hand": [62, 35]}},
         "animation": {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "up"}]}}
    path = os.path.join(folder, "arm.json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def signed(r):
    U, F = r.deformed, r.triangles
    a, b, c = U[F[:, 0]], U[F[:, 1]], U[F[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def covered_twice(r, step=0.5) -> int:
    """Sample points (every ``step`` px) inside two or more of a layer's triangles: the
    layer folded over itself."""
    U, F = r.deformed, r.triangles
    lo, hi = U.min(axis=0), U.max(axis=0)
    X, Y = np.meshgrid(np.arange(lo[0], hi[0], step) + 0.013, np.arange(lo[1], hi[1], step) + 0.029)
    P = np.c_[X.ravel(), Y.ravel()]
    count = np.zeros(len(P), int)
    for a, b, c in U[F]:
        s = np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        inside = np.ones(len(P), bool)
        for p, q in ((a, b), (b, c), (c, a)):
            inside &= s * ((q[0] - p[0]) * (P[:, 1] - p[1]) - (q[1] - p[1]) * (P[:, 0] - p[0])) > 0
        count += inside
    return int((count >= 2).sum())


def test_rigid_swing_keeps_the_arm_where_linear_folds_it(tmp_path):
    sc = puppet.load_scene(arm_scene(str(tmp_path)))
    rest = sc.layers("rest")[1]
    a0 = signed(rest)
    up = sc.layers("up")[1]
    for t in (0.0, 1.0):  # at the keys: exactly the solved poses, in both modes
        want = rest if t == 0 else up
        for mode in ("rigid", "linear"):
            sc.set_inbetween(mode)
            assert np.array_equal(sc.layers(time=t)[1].deformed, want.deformed)
    sc.set_inbetween("linear")
    lin = sc.layers(time=0.5)[1]
    sc.set_inbetween("rigid")
    rig = sc.layers(time=0.5)[1]
    ratio_lin, ratio_rig = signed(lin) / a0, signed(rig) / a0
    # straight-line pin paths meet at the shoulder: the arm collapses, its hand on its shoulder
    hand = lambda r: np.linalg.norm(r.deformed[r.pins["hand"]] - r.deformed[r.pins["shoulder"]])  # noqa: E731
    assert hand(lin) < 5 and ratio_lin.min() < 0.2 and covered_twice(lin) > 50
    # the rigid in-between turns it: the same length, no triangle squashed or folded
    assert hand(rig) == pytest.approx(70, abs=0.5) and ratio_rig.min() > 0.95 and ratio_rig.max() < 1.05
    assert covered_twice(rig) == 0 and covered_twice(rest) == 0
    for t in np.arange(0.1, 1.0, 0.1):
        r = sc.layers(time=float(t))[1]
        assert (signed(r) / a0).min() > 0.9
        assert hand(r) == pytest.approx(70, abs=0.5)


def test_rigid_frames_depend_only_on_keys_and_time(tmp_path):
    path = arm_scene(str(tmp_path))
    sc = puppet.load_scene(path)
    fresh = puppet.load_scene(path).layers(time=0.35)[1].deformed
    for t in (0.9, 0.1, 0.6, 0.35, 0.2):
        sc.layers(time=t)
    assert np.array_equal(sc.layers(time=0.35)[1].deformed, fresh)


def test_linear_interpolate_is_the_v1_blend(make_scene):
    """With "inbetween": "linear", "depth": "interpolate" a v1 animation's frames are the
    v1 ones: the eased blend of the two poses around t, solved."""
    from puppet.scene.time import evaluate as ev

    s = bar_scene()
    s["poses"]["deep"] = {"right": {"to": [95, 30], "angle": 20, "depth": 4}, "left": [18, 22]}
    s["animation"] = {"fps": 10, "inbetween": "linear", "depth": "interpolate",
                      "keys": [{"time": 0, "pose": "bend"}, {"time": 2, "pose": "deep", "ease": "smooth"}]}
    sc = puppet.load_scene(make_scene(s, {"bar.png": bar_image()}))
    u = 0.75 ** 2 * (3 - 2 * 0.75)
    want = ev.blend(sc.state("bend"), sc.state("deep"), u, np.zeros((0, 2)))
    got = sc.state(time=1.5)
    for f in ("to", "angle", "depth"):
        assert np.allclose(getattr(got, f), getattr(want, f))
    assert np.array_equal(sc.layers(time=1.5)[0].deformed, sc.rig.evaluate(sc.built, want)[0].deformed)
