"""The exact solve a release runs stays bit for bit what it was before issue 31 (the MLS
weights are now computed once per group version), and the Anderson opt-in is read with
one-line errors.

The reference is the old path: the object-space MLS and the depth field as they were
(weights from the distances on every call, copied here) put back where the solver calls
them, on the same precomputation."""
import json
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
import pytest

import puppet
import puppet.deform.arap as arap_module
import puppet.deform.hinge as hinge_module
import puppet.deform.rotate as rotate_module
import puppet.scene.rig.core as rig_core
import puppet.scene.rig.solve as solve_module
from puppet.cli import main
from puppet.deform import factor
from puppet.deform.arap import arap_solve
from puppet.deform.mls import inverse_distance_weights, mls_from_weights
from puppet.errors import SceneError
from puppet.scene.rig.solve import solve_group
from tests.conftest import SCENES
from tests.scene.test_fit_modes import arm_images, arm_scene, strip_images, strip_scene
from tests.scene.test_methods import l_scene, l_shape


def old_mls_object_space(V, D, q, p=None, *, kind="rigid", alpha=1.0, weights=None):
    """Object-space MLS before issue 31 (``weights`` ignored: computed from D every time)."""
    V = np.asarray(V, np.float64)
    p, q = np.asarray(p, np.float64).reshape(-1, 2), np.asarray(q, np.float64).reshape(-1, 2)
    if len(p) == 0:
        return V.copy()
    W, exact, reachable = inverse_distance_weights(D, alpha=alpha)
    U = V.copy()
    todo = reachable & (exact < 0)
    if todo.any():
        U[todo] = mls_from_weights(V[todo], p, q, W[:, todo], kind=kind)
    hit = exact >= 0
    U[hit] = q[exact[hit]]
    return U


def old_depth_field(D, pin_depth, *, alpha=1.0, weights=None):
    """The depth field before issue 31."""
    D = np.asarray(D, np.float64)
    z_pin = np.asarray(pin_depth, np.float64).reshape(-1)
    n = D.shape[1]
    if not z_pin.any():
        return np.zeros(n)
    W, exact, reachable = inverse_distance_weights(D, alpha=alpha)
    z = np.zeros(n)
    todo = reachable & (exact < 0)
    Wt = W[:, todo]
    z[todo] = (z_pin @ Wt) / Wt.sum(axis=0)
    hit = exact >= 0
    z[hit] = z_pin[exact[hit]]
    z[todo] = np.clip(z[todo], z_pin.min(), z_pin.max())
    return z


@contextmanager
def old_path(monkeypatch):
    """Inside: the solver calls the old functions."""
    with monkeypatch.context() as m:
        for mod in (arap_module, rotate_module, solve_module, hinge_module):
            m.setattr(mod, "mls_object_space", old_mls_object_space)
        m.setattr(solve_module, "depth_field", old_depth_field)
        yield m


def assert_release_unchanged(path, poses, monkeypatch):
    sc = puppet.load_scene(path)
    built = sc.built
    checked = 0
    for pose in poses:
        state = sc.state(pose)
        for gi, g in enumerate(built.groups):
            args = (built.pre[gi], g, sc.data.deformer, built.exterior[gi], built.group_pose(gi, state))
            with old_path(monkeypatch):
                ref = solve_group(*args)
            for _ in range(2):  # the first solve may compute the kept weights, the second uses them
                new = solve_group(*args)
                for a, b in zip(ref, new):
                    assert np.array_equal(a, b), (path, pose, gi)
            checked += 1
    assert checked >= len(poses)


def test_the_reference_is_the_old_path(make_scene, monkeypatch):
    """The patch reaches the solver's callers (else the comparisons would compare the new
    code with itself): the plain, rotated and depth paths all call the old functions."""
    s = l_scene()
    s["pins"][0]["depth"] = 1.0
    sc = puppet.load_scene(make_scene(s, {"l.png": l_shape()}))
    calls = []
    for pose in ("lift", "turn"):
        with old_path(monkeypatch) as m:
            for mod in (arap_module, rotate_module):
                m.setattr(mod, "mls_object_space", lambda *a, name=mod.__name__, **k: calls.append(name)
                          or old_mls_object_space(*a, **k))
            m.setattr(solve_module, "depth_field", lambda *a, **k: calls.append("depth") or old_depth_field(*a, **k))
            b = sc.built
            solve_group(b.pre[0], b.groups[0], sc.data.deformer, b.exterior[0], b.group_pose(0, sc.state(pose)))
    assert calls.count("depth") == 2 and "puppet.deform.arap" in calls and "puppet.deform.rotate" in calls


def test_trex_layers_poses(monkeypatch):
    assert_release_unchanged(f"{SCENES}/trex-layers.json", ["roar", "wave", "step"], monkeypatch)


def test_hinge_link(make_scene, monkeypatch):
    assert_release_unchanged(make_scene(arm_scene(points=[[200, 125]]), arm_images()), ["up"], monkeypatch)


@pytest.mark.parametrize("mode", ["rigid", "similar"])
def test_painted_stiffness_starch_and_modes(make_scene, monkeypatch, mode):
    path = make_scene(strip_scene(stiffness=True, mode=mode, starch=True), strip_images())
    assert_release_unchanged(path, ["bend"], monkeypatch)


def test_rotated_pin_exterior_points_and_depths(make_scene, monkeypatch):
    s = l_scene()
    s["layers"][0]["exterior"] = {"auto": True, "beta": 3}
    s["pins"].append({"name": "tip", "layer": "L", "at": [149.5, 40], "kind": "exterior"})
    s["pins"][0]["depth"] = 1.5
    s["poses"]["both"] = {"head": {"to": [140, 20], "angle": 25, "depth": -2}, "tip": [158, 40]}
    assert_release_unchanged(make_scene(s, {"l.png": l_shape()}), ["lift", "turn", "both"], monkeypatch)


def test_mls_method(make_scene, monkeypatch):
    path = make_scene(l_scene("mls"), {"l.png": l_shape()})
    assert_release_unchanged(path, ["lift"], monkeypatch)


# -- the Anderson opt-in ----------------------------------------------------------------
def test_anderson_release_is_near_the_converged_pose(make_scene):
    """Opted in, the release is the converged pose within the tolerance's reach, where the
    default 20 iterations are not."""
    plain = l_scene()
    fast = l_scene(deformer={"method": "arap", "accelerate": "anderson", "tolerance": 0.001, "iterations": 400})
    long = l_scene(deformer={"method": "arap", "iterations": 3000})
    imgs = {"l.png": l_shape()}
    a, b, c = (puppet.load_scene(make_scene(s, imgs, name=f"{n}.json")).layers("lift")[0]
               for n, s in (("a", fast), ("b", long), ("c", plain)))
    assert np.abs(a.deformed - b.deformed).max() < 0.05
    assert np.abs(c.deformed - b.deformed).max() > 5 * np.abs(a.deformed - b.deformed).max()


@pytest.mark.parametrize("deformer, path, what", [
    ({"accelerate": "fast"}, "deformer.accelerate", "'fast' is not one of: none, anderson"),
    ({"accelerate": 1}, "deformer.accelerate", "expected a string"),
    ({"accelerate": "anderson", "tolerance": 0}, "deformer.tolerance", "must be > 0, got 0"),
    ({"accelerate": "anderson", "tolerance": "small"}, "deformer.tolerance", "expected a number"),
    ({"accelerate": "anderson", "tolerance": 1e9}, "deformer.tolerance", "must be <= 100"),
    ({"tolerance": 0.1}, "deformer.tolerance", "needs \"accelerate\": \"anderson\""),
    ({"accelerate": "anderson", "method": "igarashi"}, "deformer.accelerate", "needs method 'arap'"),
    ({"accelerate": "anderson", "mode": "similar"}, "deformer.mode", "cannot be accelerated"),
])
def test_bad_accelerate_values_are_one_line_errors(make_scene, capsys, deformer, path, what):
    s = l_scene(deformer=deformer)
    file = make_scene(s, {"l.png": l_shape()})
    with pytest.raises(SceneError) as err:
        puppet.load_scene(file)
    msg = str(err.value)
    assert "\n" not in msg and "scene.json" in msg and path in msg and what in msg, msg
    assert main(["check", file]) == 2
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and path in captured.err


def test_a_layer_mode_refuses_acceleration(make_scene):
    s = l_scene(deformer={"accelerate": "anderson"})
    s["layers"][0]["deformer"] = {"mode": "distort"}
    with pytest.raises(SceneError, match=r"layers\[0\]\.deformer\.mode: mode 'distort' cannot be accelerated"):
        puppet.load_scene(make_scene(s, {"l.png": l_shape()}))


def test_opt_in_round_trips_through_save(make_scene, tmp_path):
    s = l_scene(deformer={"accelerate": "anderson", "tolerance": 0.05})
    sc = puppet.load_scene(make_scene(s, {"l.png": l_shape()}))
    assert (sc.data.deformer.accelerate, sc.data.deformer.tolerance) == ("anderson", 0.05)
    out = tmp_path / "saved.json"
    sc.save(str(out))
    assert json.loads(out.read_text())["deformer"]["accelerate"] == "anderson"
    assert puppet.load_scene(str(out)).data.deformer.tolerance == 0.05


def test_warm_start_reaches_the_same_pose_and_the_default_ignores_it(make_scene):
    sc = puppet.load_scene(make_scene(l_scene(), {"l.png": l_shape()}))
    b = sc.built
    pre, g, ext = b.pre[0], b.groups[0], b.exterior[0]
    pose = b.group_pose(0, sc.state("lift"))
    preview = arap_solve(pre.arap, pose.bc, iterations=4, U0=g.mesh.V)  # a rough preview
    d = sc.data.deformer
    assert all(np.array_equal(x, y) for x, y in zip(solve_group(pre, g, d, ext, pose, warm=preview),
                                                    solve_group(pre, g, d, ext, pose)))
    fast = replace(d, accelerate="anderson", tolerance=1e-4, iterations=2000)
    warm = solve_group(pre, g, fast, ext, pose, warm=preview)[0]
    cold = solve_group(pre, g, fast, ext, pose)[0]
    assert np.abs(warm - cold).max() < 0.02
    assert np.abs(preview - cold).max() > 1.0  # the preview itself was not the answer


def test_a_pose_edit_keeps_the_clipped_links_and_a_link_edit_redoes_them(make_scene):
    """The links clipped to the masks and the triangle areas are kept across pose edits (a
    release's commit), and rebuilt when a link or a mesh option changes."""
    path = make_scene(arm_scene(segments=[[[185, 125], [215, 125]]]), arm_images())
    sc = puppet.load_scene(path)
    sc.built
    n = sc.rig.memo.count("links")
    sc.set_target("tip", (250, 40), pose="up")
    assert sc.rig.memo.count("links") == n
    fresh = puppet.load_scene(path)
    fresh.set_target("tip", (250, 40), pose="up")
    for a, b in zip(sc.layers(), fresh.layers()):
        assert np.array_equal(a.deformed, b.deformed)
    sc.add_link_point("body", "arm", (200, 125))
    assert sc.rig.memo.count("links") == n + 1
    sc.set_mesh_options("arm", max_area=30.0)
    assert sc.rig.memo.count("links") == n + 2
    assert len(sc.built.groups[0].hinges) == 1


@pytest.mark.parametrize("accelerate", ["none", "anderson"])
def test_a_release_starts_from_the_previews_only_when_opted_in(make_scene, monkeypatch, accelerate):
    """Opted in, the release's accelerated solve starts from the drag's last preview and
    lands where a cold solve of the same pose does (within the tolerance's reach);
    otherwise the release is the cold solve bit for bit. Neither refactorises."""
    deformer = {"accelerate": accelerate, "tolerance": 1e-4, "iterations": 2000} if accelerate != "none" else {}
    path = make_scene(l_scene(deformer=deformer), {"l.png": l_shape()})
    starts = []
    real = rig_core.solve_group
    monkeypatch.setattr(rig_core, "solve_group", lambda *a, warm=None: starts.append(warm) or real(*a, warm=warm))
    sc = puppet.load_scene(path)
    sc.layers()
    d = sc.drag("head")
    made = factor.FACTORIZATIONS
    for k in range(1, 6):
        d.move_layers((130 + 2 * k, 30 - 3 * k))
    released = d.release_layers()
    assert factor.FACTORIZATIONS == made  # only targets moved: the factor is reused
    cold = puppet.load_scene(path)
    cold.set_target("head", (140, 15))
    gap = max(np.abs(a.deformed - b.deformed).max() for a, b in zip(released, cold.layers()))
    if accelerate == "none":
        assert gap == 0 and all(w is None for w in starts)
    else:
        assert gap < 0.02 and any(w is not None for w in starts)


def test_an_accelerated_scene_may_take_more_iterations_unless_it_says(make_scene):
    imgs = {"l.png": l_shape()}
    sc = puppet.load_scene(make_scene(l_scene(deformer={"accelerate": "anderson"}), imgs, name="a.json"))
    assert sc.data.deformer.iterations == 300
    sc = puppet.load_scene(make_scene(l_scene(deformer={"accelerate": "anderson", "iterations": 40}), imgs))
    assert sc.data.deformer.iterations == 40
    assert puppet.load_scene(make_scene(l_scene(), imgs, name="c.json")).data.deformer.iterations == 20
