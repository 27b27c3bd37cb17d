"""Every public method of the Python API, called with hostile arguments (wrong types, NaN,
inf, negative and huge numbers, strings, None, wrong-shaped arrays, bools where a number
is meant), raises a SceneError naming the method and the argument, or succeeds; never
another exception, and no warning. A refused call leaves the scene as it was and writes no file
(issue 30, case 6: the editing API raised ZeroDivisionError, ValueError, TypeError and
numpy errors, and accepted NaN or negative stiffness and ``iterations=-5``)."""
from __future__ import annotations

import inspect
import json
import os
import pathlib
import re
import subprocess
import sys
import types
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import puppet
from puppet.api import Drag, Scene
from puppet.errors import SceneError
from puppet.scene.drag.session import DragSession
from puppet.scene.format.args import MAX_PIXELS, MAX_SIDE
from tests.conftest import bar_image, write_rgba
from tests.fstree import snapshot
from tests.scene.document.test_edits import three_bars


def scene_dict() -> dict:
    d = three_bars()
    d["pins"].append({"name": "s1", "layer": "a", "at": [60, 20], "kind": "starch"})
    return d


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("api-args")
    write_rgba(root / "bar.png", bar_image())
    (root / "out").mkdir()
    (root / "scene.json").write_text(json.dumps(scene_dict()))
    return root


@pytest.fixture(scope="module")
def scene(folder):
    s = puppet.load_scene(str(folder / "scene.json"))
    yield s
    s.close()


# -- hostile values ----------------------------------------------------------------------
ODD = [None, True, False, np.bool_(True), 0, -1, -5, 2 ** 70, -(2 ** 70), 10 ** 400, 0.0, -0.0, 1e-300, -1e300,
       1e300, float("nan"), float("inf"), float("-inf"), np.float32("nan"), np.int64(-5), np.float64(1e308), 1 + 2j,
       "", "x", "a1", "up", "rest", "b", "nan", "1", "\0", b"ab", object(), [], (), {}, set(), [None], [1],
       [1, 2, 3], (float("nan"), 1.0), ("1", "2"), [[1, 2], [3]], {"a1": "x"}, {"to": [1, 2]}, {1: 2},
       {"a1": [float("nan"), 0]}, {0.5: {"a1": "x"}}, {-1: {"a1": [1, 2]}}, (0, 0), (100000, 100000), (16384, 16384),
       (True, False), (1.5, 2), (-3, 4), [5, 5], np.zeros(0), np.zeros((2,)), np.zeros((3, 3)), np.full((2,), np.nan),
       np.zeros((40, 120)), np.full((40, 120), np.nan), np.full((40, 120), -5.0), np.full((40, 120), 300.0),
       np.full((40, 120), np.inf), np.ones((40, 120), bool), np.zeros((40, 120, 4), np.uint8),
       np.full((4, 4, 4), -1.0), np.zeros((40, 120, 3)), np.array(["a", "b"]), np.array([object(), 1])]
scalars = st.one_of(st.sampled_from(ODD), st.integers(-(2 ** 70), 2 ** 70), st.floats(), st.text(max_size=6))
containers = st.recursive(scalars, lambda c: st.one_of(st.lists(c, max_size=4), st.tuples(c, c),
                                                       st.dictionaries(st.text(max_size=4), c, max_size=3)),
                          max_leaves=6)
arrays = hnp.arrays(st.sampled_from([np.float64, np.uint8, np.bool_, np.int64]),
                    hnp.array_shapes(min_dims=0, max_dims=3, max_side=4))
HOSTILE = st.one_of(scalars, containers, arrays)
#: paths: never one that could reach outside the test's folder
PATHS = st.sampled_from([None, 5, 1.5, b"bytes", "", "\0", "a\0b", ".", "no/such/folder/x.json", [], {}, object(),
                         np.zeros(2), True])
FIELD_NAMES = ["offset", "mask", "order", "inpaint", "mesh", "exterior", "deformer", "stiffness", "bogus",
               "method", "iterations", "alpha", "max_area", "min_angle", "simplify", "relax_foldovers"]
KWARGS = st.dictionaries(st.sampled_from(FIELD_NAMES), HOSTILE, min_size=1, max_size=2)
PATH_ARGS = {"path", "folder", "image", "scene_file"}


def valid_calls(folder) -> dict:
    """A call of each public method that succeeds on the scene: (args, kwargs)."""
    bar = str(folder / "bar.png")
    square = [[20, 5], [60, 5], [60, 35], [20, 35]]
    return {
        "add_pin": (("n1", "a", (60, 20)), {"depth": 1.0, "kind": "interior"}),
        "remove_pin": (("a1",), {}),
        "move_pin": (("b1", (20, 72)), {}),
        "rename_pin": (("c1", "tip"), {}),
        "set_pin": (("b1",), {"depth": -1.5, "kind": "interior"}),
        "add_layer": (("d",), {"image": bar, "index": 1, "offset": (60, 0)}),
        "remove_layer": (("c",), {}),
        "reorder_layer": (("a", -1), {}),
        "rename_layer": (("b", "body"), {}),
        "set_layer": (("a",), {"order": 2}),
        "set_mask": (("a", {"rect": [0, 12, 120, 16]}), {}),
        "set_cage": (("a", {"points": [[5, 5], [115, 5], [115, 35], [5, 35]], "coordinates": "mvc"}), {}),
        "set_physics": (([{"pins": ["a1", "b1"], "frequency": 3.0}],), {}),
        "set_animation": (({"fps": 12, "keys": [{"time": 0, "pins": {"a1": [10, 10]}}]},), {"label": "motion"}),
        "set_inpaint": (("a", "telea"), {}),
        "set_mesh_options": (("a",), {"max_area": 20}),
        "set_mask_pixels": (("a", np.ones((40, 120), bool)), {}),
        "set_layer_pixels": (("a", np.full((40, 120, 4), 200, np.uint8)), {}),
        "split_layer": (("a", square, "part"), {"cut": False}),
        "add_link": (("b", "c", [[75, 65], [75, 75]]), {}),
        "add_rig": (([{"name": "r1", "layer": "a", "at": [61, 21]}], []), {"deformer": {"method": "arap"}}),
        "remove_link": (("b", "c"), {"segment": 0}),
        "remove_link_part": (("b", "c", "segments", 0), {}),
        "add_pose": (("wave",), {"like": "up", "activate": False}),
        "rename_pose": (("up", "raise"), {}),
        "delete_pose": (("up",), {}),
        "set_active_pose": (("up",), {}),
        "set_target": (("a1", (20, 30)), {"angle": 5.0, "depth": 1.0, "pose": "up"}),
        "clear_target": (("a2",), {"pose": "up"}),
        "set_underlay": ((bar,), {"opacity": 0.3, "offset": (1, 2), "scale": 2.0}),
        "set_deformer": ((), {"iterations": 7}),
        "set_key": ((0.5,), {"pose": "up", "ease": "bezier", "curve": [0.2, 0, 0.8, 1], "overrides": {"a1": [10, 20]}}),
        "record_motion": (({0.2: {"a1": [20, 20]}, 0.4: {"a1": [25, 20]}},), {"start": 0.1, "end": 0.5}),
        "key_pins": ((0.5, {"a1": [20, 21]}), {}),
        "remove_key": ((1.0,), {}),
        "move_key": ((1.0, 2.0), {}),
        "copy_key": ((1.0, 2.0), {}),
        "set_key_ease": ((1.0, "smooth"), {"curve": None}),
        "set_fps": ((30,), {}),
        "set_inbetween": (("linear",), {}),
        "set_depth_mode": (("interpolate",), {}),
        "key_times": ((), {"pin": "a1"}),
        "pose_at": ((0.5,), {}),
        "set_stiffness_pixels": (("b", np.full((40, 120), 128.0)), {}),
        "set_pin_radius": (("s1", 10.0), {}),
        "add_link_point": (("b", "c", (90, 70)), {}),
        "add_link_polygon": (("b", "c", [(80, 64), (100, 64), (100, 76), (80, 76)]), {}),
        "set_link_strength": (("b", "c", 0.25), {}),
        "state": ((None, 0.5), {}),
        "layers": ((), {"time": 0.5}),
        "mesh": ((), {"pose": "up"}),
        "parse_pose": (({"a2": [100, 8]},), {"where": "pose"}),
        "to_json": ((str(folder),), {}),
        "save": ((str(folder / "out" / "saved.json"),), {"copy": False, "follow": True}),
        "adopt_files": ((str(folder),), {}),
        "write_mesh": ((str(folder / "out" / "mesh.json"),), {"pose": "up"}),
        "block": (("label",), {}),
        "drag": (("a1",), {"time": None, "record": False, "iterations": 4, "size": (50, 40), "solver": None}),
        "load": ((str(folder / "scene.json"),), {}),
        "from_image": ((bar,), {"layer": "one", "scene_file": str(folder / "new.json")}),
    }


#: public methods that draw (a GL context): tested in test_drawing_methods_check_first
DRAWING = {"render": ((), {"pose": "up", "time": None, "size": (50, 40), "wireframe": False}),
           "draw_layers": ((None,), {"size": (50, 40), "wireframe": False, "background": (1, 2, 3, 4), "reduce": 1,
                                     "canvas": None}),
           "pin_depth": ((None,), {"canvas": (50, 40)})}
#: methods of a drag: (args, kwargs) on a fresh drag of a1
DRAG_CALLS = {"move_layers": (((30, 20),), {"time": None}), "commit": ((), {"keys": None}),
              "release_layers": ((), {"keys": None}), "cancel": ((), {})}
DRAG_DRAWING = {"move": (((30, 20),), {"time": None}), "release": ((), {"keys": None})}
NO_ARGS = {"to_dict", "undo", "redo", "background", "underlay_image", "pose_names", "tracks", "summary",
           "not_applied", "keys", "duration", "close"}


def public_methods(cls) -> list[str]:
    return sorted(n for n, f in inspect.getmembers(cls) if not n.startswith("_") and callable(f)
                  and not isinstance(inspect.getattr_static(cls, n), property))


def test_every_public_method_checks_its_arguments(folder):
    calls = valid_calls(folder)
    for cls, known in ((Scene, set(calls) | set(DRAWING) | NO_ARGS), (Drag, set(DRAG_CALLS) | set(DRAG_DRAWING))):
        for name in public_methods(cls):
            fn = inspect.getattr_static(cls, name)
            fn = getattr(fn, "__func__", fn)  # classmethods
            if name == "block":
                fn = fn.__wrapped__  # contextmanager over the checked generator
            assert hasattr(fn, "__checks__"), f"{cls.__name__}.{name} is not wrapped by args.checked"
            assert name in known, f"{cls.__name__}.{name} has no call in this test"
            params = [p for p in inspect.signature(fn).parameters if p not in ("self", "cls")]
            unchecked = set(params) - set(fn.__checks__)
            assert not unchecked, f"{cls.__name__}.{name}: {unchecked} unchecked"
    assert issubclass(Drag, DragSession)


def _call(obj, name, args, kwargs):
    out = getattr(obj, name)(*args, **kwargs)
    if name == "block":
        with out:
            pass
    if isinstance(out, DragSession):
        out.cancel()
    return out


def _hostile_call(obj, folder, name, args, kwargs, data, scene=None):
    """Replace one argument of a valid call of ``obj.name`` by a hostile value; call;
    check the outcome (``scene``: the scene ``obj`` belongs to, default ``obj``)."""
    scene = obj if scene is None else scene
    fn = getattr(obj, name)
    sig = inspect.signature(fn)
    params = list(sig.parameters.values())
    if not params:
        return
    p = data.draw(st.sampled_from(params), label="argument")
    bound = sig.bind_partial(*args, **kwargs)
    if p.kind is inspect.Parameter.VAR_KEYWORD:
        bound.arguments[p.name] = data.draw(KWARGS, label="fields")
    else:
        strategy = PATHS if p.name in PATH_ARGS else HOSTILE
        bound.arguments[p.name] = data.draw(strategy, label=p.name)
    before = (scene.to_dict(), scene.active_pose, len(scene.history.undo_stack))
    files = snapshot(str(folder))
    pending = snapshot(scene.pending.folder)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a warning (numpy's, a ComplexWarning) is noise a user sees: a fault
            _call(obj, name, bound.args, bound.kwargs)
    except SceneError as e:
        assert "\n" not in str(e)
        assert (scene.to_dict(), scene.active_pose, len(scene.history.undo_stack)) == before
        assert snapshot(str(folder)) == files
        assert snapshot(scene.pending.folder) == pending
    finally:
        while scene.undo():
            pass
        scene.history.redo_stack.clear()


#: PUPPET_API_ARGS_EXAMPLES=500 for a longer search
HOSTILE_SETTINGS = settings(max_examples=int(os.environ.get("PUPPET_API_ARGS_EXAMPLES", "40")), deadline=None,
                            database=None,
                            suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.mark.parametrize("name", sorted(set(valid_calls(pathlib.Path("/x"))) - {"load", "from_image"}))
@HOSTILE_SETTINGS
@given(data=st.data())
def test_hostile_arguments_give_a_scene_error_or_success(scene, folder, name, data):
    args, kwargs = valid_calls(folder)[name]
    _call(scene, name, args, kwargs)  # the valid call succeeds
    while scene.undo():
        pass
    _hostile_call(scene, folder, name, args, kwargs, data)


@pytest.mark.parametrize("name", sorted(DRAG_CALLS))
@HOSTILE_SETTINGS
@given(data=st.data())
def test_hostile_drag_arguments(scene, folder, name, data):
    _hostile_drag_call(scene, folder, name, DRAG_CALLS, data)


def _hostile_drag_call(scene, folder, name, table, data, **drag_kw):
    """One method of a drag on pin a1 called with hostile arguments; the drag cancelled
    and every edit undone after."""
    d = scene.drag("a1", **drag_kw)
    try:
        _hostile_call(d, folder, name, *table[name], data, scene=scene)
    finally:
        d.cancel()
        while scene.undo():
            pass


@HOSTILE_SETTINGS
@given(data=st.data())
def test_hostile_arguments_to_make_a_drag(scene, folder, data):
    """``DragSession(doc, names, ...)`` and ``Drag(scene, ...)`` made directly check theirs too."""
    makers = types.SimpleNamespace(DragSession=DragSession, Drag=Drag)
    name = data.draw(st.sampled_from(["DragSession", "Drag"]))
    kwargs = {"time": None, "record": False, "iterations": 4, "solver": None}
    _hostile_call(makers, folder, name, (scene, "a1"), dict(kwargs, size=(50, 40)) if name == "Drag" else kwargs,
                  data, scene=scene)


@pytest.mark.parametrize("name", ["load", "from_image"])
@HOSTILE_SETTINGS
@given(data=st.data())
def test_hostile_paths_to_open(folder, name, data):
    args, kwargs = valid_calls(folder)[name]
    files = snapshot(str(folder))
    v = data.draw(PATHS | HOSTILE if name == "from_image" and data.draw(st.booleans()) else PATHS)
    try:
        getattr(Scene, name)(v, **({} if name == "load" else {"layer": "one"}))
    except SceneError as e:
        assert "\n" not in str(e)
    assert snapshot(str(folder)) == files


# -- the cases of the issue, one by one ----------------------------------------------------
@pytest.mark.parametrize("call, words", [
    (lambda s: s.drag("a1", size=(0, 0)), f"drag: size must be two whole numbers 1..{MAX_SIDE} of at most "
                                          f"{MAX_PIXELS} pixels, got (0, 0)"),
    (lambda s: s.drag("a1", size=(100000, 100000)), "got (100000, 100000)"),
    (lambda s: s.render(size=(100000, 100000)), "render: size must be two whole numbers"),
    (lambda s: s.render(size=(16384, 16384)), f"at most {MAX_PIXELS} pixels, got (16384, 16384)"),
    (lambda s: s.drag("a1", iterations=-5), "drag: iterations must be a whole number 1..10000, got -5"),
    (lambda s: s.drag("a1", iterations=True), "drag: iterations must be a whole number 1..10000, got True"),
    (lambda s: s.drag("a1").move_layers("ab"), "move_layers: targets must be two finite numbers"),
    (lambda s: s.set_target("a1", "xy"), "set_target: to must be two finite numbers"),
    (lambda s: s.set_stiffness_pixels("b", np.ones((3, 3))),
     "set_stiffness_pixels: grey must be the size of the image of layer 'b', (h, w) = (40, 120)"),
    (lambda s: s.set_stiffness_pixels("b", np.full((40, 120), np.nan)), "grey must hold finite numbers 0..255"),
    (lambda s: s.set_stiffness_pixels("b", np.full((40, 120), -1.0)), "grey must hold finite numbers 0..255"),
    (lambda s: s.save(5), "save: path must be a file path"),
])
def test_the_issue_cases(scene, folder, call, words):
    before = scene.to_dict()
    files = snapshot(str(folder))
    with pytest.raises(SceneError, match=re.escape(words)) as e:
        call(scene)
    assert str(e.value).startswith(f"{scene.file}: ") and "\n" not in str(e.value)
    assert scene.to_dict() == before
    assert snapshot(str(folder)) == files


def test_messages_name_the_file_the_method_and_the_argument(scene):
    with pytest.raises(SceneError) as e:
        scene.drag("a1", size=(0, 0))
    assert str(e.value).startswith(f"{scene.file}: drag: size must ")
    assert e.value.file == scene.file


def test_the_command_line_reaches_the_same_checks(folder, tmp_path):
    """``puppet render --size`` refuses a huge size in one line, exit 2 (the parser's own check)."""
    r = subprocess.run([sys.executable, "-m", "puppet", "render", str(folder / "scene.json"), "--size", "100000x100000",
                        "-o", str(tmp_path / "o.png")], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("puppet: error:")
    assert "Traceback" not in r.stderr
    assert not os.listdir(tmp_path)


# -- drawing ---------------------------------------------------------------------------------
@pytest.mark.gl
@pytest.mark.parametrize("name", sorted(DRAWING))
@HOSTILE_SETTINGS
@given(data=st.data())
def test_drawing_methods_check_first(scene, folder, name, data):
    args, kwargs = DRAWING[name]
    if name in ("draw_layers", "pin_depth"):
        args = (scene.layers("up"),)
    _hostile_call(scene, folder, name, args, kwargs, data)


@pytest.mark.gl
@pytest.mark.parametrize("name", sorted(DRAG_DRAWING))
@HOSTILE_SETTINGS
@given(data=st.data())
def test_drawing_drag_methods_check_first(scene, folder, name, data):
    _hostile_drag_call(scene, folder, name, DRAG_DRAWING, data, size=(50, 40))


@pytest.mark.gl
def test_a_size_this_machines_gl_cannot_draw_is_refused_in_one_line(folder, monkeypatch):
    import puppet.render.context as context

    s = puppet.load_scene(str(folder / "scene.json"))
    try:
        monkeypatch.setattr(context, "max_output_size", lambda ctx: 64)
        with pytest.raises(SceneError, match=re.escape("draw: a frame of 100x40 pixels cannot be drawn: this machine's "
                                                       "OpenGL draws at most 64x64")):
            s.render(size=(100, 40))
        assert s.render(size=(64, 32)).shape == (32, 64, 4)
    finally:
        s.close()


@pytest.mark.parametrize("call", [
    lambda s: s.set_layer_pixels("a", np.zeros((40, 120, 4), np.uint8)),  # all transparent: selects nothing
    lambda s: s.set_mask_pixels("a", np.zeros((40, 120), bool)),
    lambda s: s.split_layer("a", [[0, 0], [5, 0], [5, 5], [0, 5]], "part"),
], ids=["layer pixels", "mask pixels", "split"])
def test_a_refused_pixels_edit_leaves_no_png_behind(scene, folder, call):
    before = scene.to_dict()
    pending = snapshot(scene.pending.folder)
    with pytest.raises(SceneError):
        call(scene)
    assert scene.to_dict() == before
    assert snapshot(scene.pending.folder) == pending


@pytest.mark.parametrize("value", [None, 5, "gl", object()])
def test_a_compositor_that_is_not_one_is_refused(scene, value):
    with pytest.raises(SceneError, match="compositor must be a puppet.render.compositor.Compositor"):
        scene.compositor = value
    assert scene._compositor is None or scene._compositor is not value
