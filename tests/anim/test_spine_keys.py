"""Spine's deform keys reduced to the scene's keys plus what interpolation needs: the
written keys, replayed the way the Spine runtimes interpolate them (computed here from the
JSON, curve and all), stay within 1 px of puppet's solved frames; ``--tolerance 0``
writes the deform timelines the exporter wrote before keys were reduced (a key on every
frame, checked against that writer, kept below); the key planner on hand-made motions."""
from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest

import puppet.anim.spine as spine
from puppet.anim.keys import Key, curve_points, plan, scene_frames, span_error
from puppet.anim.options import KEY_TOLERANCE
from puppet.cli import main
from puppet.geom.mesh import boundary_edges

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TREX = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")


# -- Spine's interpolation, as the runtimes compute it -----------------------------------
def runtime_samples(t1: float, t2: float, curve) -> list[tuple[float, float]]:
    """The 9 (time, fraction) samples a runtime keeps of a deform key's Bezier curve: the
    cubic from (t1, 0) over (cx1, cy1), (cx2, cy2) to (t2, 1), stepped by forward
    differences at parameter steps of 0.1 (the runtimes' ``setBezier``)."""
    cx1, cy1, cx2, cy2 = curve
    h = 0.1
    # the cubic's power form: x(s) = t1 + a1 s + a2 s^2 + a3 s^3 (y likewise, from 0)
    ax = (3 * (cx1 - t1), 3 * (t1 - 2 * cx1 + cx2), t2 - t1 + 3 * (cx1 - cx2))
    ay = (3 * cy1, 3 * (cy2 - 2 * cy1), 1 + 3 * (cy1 - cy2))
    out = []
    for a, y0 in ((ax, t1), (ay, 0.0)):
        d1 = a[0] * h + a[1] * h * h + a[2] * h ** 3
        d2 = 2 * a[1] * h * h + 6 * a[2] * h ** 3
        d3 = 6 * a[2] * h ** 3
        v, vals = y0, []
        for _ in range(9):
            v += d1
            vals.append(v)
            d1 += d2
            d2 += d3
        out.append(vals)
    return list(zip(*out))


def runtime_percent(key: dict, t1: float, t2: float, t: float) -> float:
    """A deform key's fraction at time t (t1 <= t < t2), the runtimes' ``getCurvePercent``."""
    curve = key.get("curve")
    if curve is None:
        return (t - t1) / (t2 - t1)
    if curve == "stepped":
        return 0.0
    pts = runtime_samples(t1, t2, curve)
    if pts[0][0] > t:
        return pts[0][1] * (t - t1) / (pts[0][0] - t1)
    for (xa, ya), (xb, yb) in zip(pts, pts[1:]):
        if xb >= t:
            return ya + (t - xa) / (xb - xa) * (yb - ya)
    x, y = pts[-1]
    return y + (1 - y) * (t - x) / (t2 - x)


def key_vertices(key: dict, setup: np.ndarray) -> np.ndarray:
    off = np.zeros_like(setup)
    v = key.get("vertices", [])
    start = key.get("offset", 0)
    off[start:start + len(v)] = v
    return setup + off


def replay_spine(timeline: list[dict], setup: np.ndarray, t: float) -> np.ndarray:
    """The attachment's vertices at time t (setup pose before the first key, the last key
    after the last)."""
    times = [k.get("time", 0.0) for k in timeline]
    if t < times[0]:
        return setup
    if t >= times[-1]:
        return key_vertices(timeline[-1], setup)
    i = max(j for j in range(len(times)) if times[j] <= t)
    a, b = key_vertices(timeline[i], setup), key_vertices(timeline[i + 1], setup)
    return a + runtime_percent(timeline[i], times[i], times[i + 1], t) * (b - a)


def test_runtime_samples_are_the_planners_curve():
    rng = np.random.default_rng(3)
    for _ in range(20):
        t1 = float(rng.uniform(0, 3))
        t2 = t1 + float(rng.uniform(0.05, 2))
        curve = (t1 + rng.uniform() * (t2 - t1), rng.uniform(-1, 2), t1 + rng.uniform() * (t2 - t1), rng.uniform(-1, 2))
        x, y = curve_points(t1, t2, curve)
        assert np.allclose(np.array(runtime_samples(t1, t2, curve)), np.stack([x[1:-1], y[1:-1]], 1), atol=1e-9)
        for t in np.linspace(t1, t2, 17)[:-1]:
            p = np.interp(t, x, y)
            assert abs(runtime_percent({"curve": list(curve)}, t1, t2, t) - p) < 1e-9


# -- the planner on hand-made motions ----------------------------------------------------
def motion(fraction, n: int = 25, radius: float = 100.0, move=(300.0, -120.0)):
    """Frames (n, 40, 2) of 40 points on a circle moved by ``move`` px x fraction(t)."""
    T = np.arange(n) / 12.0
    ang = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    base = radius * np.stack([np.cos(ang), np.sin(ang)], 1)
    u = np.array([fraction(t / T[-1]) for t in T])
    return base[None] + u[:, None, None] * np.array(move), T


def test_plan_keeps_the_scene_keys_and_fits_eases():
    F, T = motion(lambda u: u)
    keys = plan(F, T, [12], 0.5)
    assert keys == [Key(0), Key(12), Key(24)]  # linear motion: the scene's keys alone
    # smoothstep over the whole span, 50 px: the runtimes' 10-segment polyline of the curve
    # is within 6 / 8 / 100 of the fraction (0.38 px here)
    F, T = motion(lambda u: u * u * (3 - 2 * u), move=(40.0, -30.0))
    keys = plan(F, T, [], 0.5)
    assert [k.frame for k in keys] == [0, 24] and keys[0].curve is not None  # one curve
    assert span_error(F, T, keys) <= 0.5 < span_error(F, T, [Key(0), Key(24)])
    assert plan(F, T, [], 0.0) == [Key(f) for f in range(25)]  # tolerance 0: every frame


def test_plan_splits_where_no_curve_fits():
    T = np.arange(25) / 12.0
    ang = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    rot = np.linspace(0, np.pi / 2, 25)  # a quarter turn: a blend of the ends shrinks it
    F = np.stack([150 * np.stack([np.cos(ang + r), np.sin(ang + r)], 1) for r in rot])
    keys = plan(F, T, [], 1.0)
    assert 3 <= len(keys) < 25 and span_error(F, T, keys) <= 1.0
    assert span_error(F, T, [Key(0), Key(24)]) > 20  # the ends alone are far off


def test_scene_frames_are_the_key_times_on_frames():
    class A:
        keys = [type("K", (), {"time": t}) for t in (0.0, 0.5, 0.7, 1.0, 3.0)]
    assert scene_frames(A, 0.0, 12, 13) == [0, 6, 12]  # 0.7 s is between frames; 3 s is past the end
    assert scene_frames(A, 0.5, 10, 6) == [0, 2, 5]


# -- the written file --------------------------------------------------------------------
@pytest.fixture(scope="module")
def trex(tmp_path_factory):
    """The T-rex's whole animation (2 s, 25 frames at 12 fps) with the default tolerance,
    and puppet's solved frames as the export was handed them (``scene.layers(time=t)``)."""
    d = tmp_path_factory.mktemp("spinekeys")
    out = str(d / "trex.spine.json")
    frames = []
    add = spine.SpineSink.add
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(spine.SpineSink, "add", lambda self, layers: (frames.append(layers), add(self, layers))[1])
        assert main(["animate", TREX, "-o", out]) == 0
    assert len(frames) == 25
    with open(out) as f:
        return json.load(f), frames, os.path.getsize(out)


def test_replayed_keys_match_every_frame_within_a_pixel(trex):
    doc, frames, size = trex
    W, H = 600, 500
    atts = doc["skins"][0]["attachments"]
    timelines = doc["animations"]["animation"]["attachments"]["default"]
    written = 0
    for i, L in enumerate(frames[0]):
        setup = np.asarray(atts[L.name][L.name]["vertices"], float)
        canvas = np.stack([setup[0::2] + W / 2, H - setup[1::2]], 1)
        # the setup vertices are the rest mesh, in hull-first order
        idx = np.argmin(((np.asarray(L.rest)[None] - canvas[:, None]) ** 2).sum(2), axis=1)
        assert np.abs(np.asarray(L.rest)[idx] - canvas).max() < 0.01
        tl = timelines[L.name][L.name]["deform"]
        written += len(tl)
        assert tl[0]["time"] == 0 and abs(tl[-1]["time"] - 2.0) < 1e-9
        assert {0.0, 0.5, 1.0, 1.5, 2.0} <= {k["time"] for k in tl}  # every scene key is a key
        for f in range(25):
            v = replay_spine(tl, setup, f / 12).reshape(-1, 2)
            got = np.stack([v[:, 0] + W / 2, H - v[:, 1]], 1)
            err = np.linalg.norm(got - np.asarray(frames[f][i].deformed)[idx], axis=1).max()
            assert err < 1.0, (L.name, f, err)
    moving = len(timelines)
    assert written < 0.5 * 25 * moving  # fewer than half of the per-frame keys
    assert any("curve" in k for tl in timelines.values() for k in tl[list(tl)[0]]["deform"])
    assert size < 0.6 * 3_014_718  # the per-frame file of this animation (measured)


def _old_timelines(sink, keys, held) -> dict:
    """The deform timelines as the exporter wrote them before keys were reduced
    (7b96ca4): a key on every frame, linear."""
    deform: dict = {}
    for i in sink.slots:
        frames = keys.layer(i)
        if not any(np.any(np.abs(f) >= 0.005) for f in frames):
            continue
        timeline = []
        for f, off in enumerate(frames):
            key: dict = {"time": round(f / sink.job.fps, 6)}
            if np.any(np.abs(off) >= 0.005):
                key["vertices"] = [float(v) for v in np.round(np.asarray(off, np.float64).reshape(-1), 2)]
            timeline.append(json.dumps(key, separators=(",", ":")))
        deform[sink.names[i]] = {sink.regions[sink.slot_of[i]]: {"deform": held.add(timeline)}}
    return {"default": deform}


def test_tolerance_zero_writes_every_frame_as_before(tmp_path, monkeypatch):
    seen = []
    close = spine.SpineSink.close

    def keep(self):
        seen.append(self)
        close(self)
    monkeypatch.setattr(spine.SpineSink, "close", keep)
    out = str(tmp_path / "t.spine.json")
    assert main(["animate", TREX, "-o", out, "--to", "1", "--tolerance", "0"]) == 0
    (sink,) = seen
    with open(out) as f:
        text = f.read()
    poses = ((name, _pose(sink, offs)) for name, (offs, _) in sink.poses.items())
    for name, keys in (("animation", sink.keys), *poses):
        held = spine._Held()
        want = json.loads("".join(held.parts(json.dumps(_old_timelines(sink, keys, held), separators=(",", ":")))))
        assert json.loads(text)["animations"][name]["attachments"] == want, name
    assert '"curve"' not in text


def _pose(sink, offs):
    pose = spine._Offsets(sink.keys.starts)
    pose.append(offs)
    return pose


def test_tolerance_and_simplify_are_refused_where_they_do_not_apply(tmp_path, capsys):
    assert main(["animate", TREX, "-o", str(tmp_path / "a.gif"), "--tolerance", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("puppet: error: --tolerance does not apply") and err.count("\n") == 1
    assert main(["animate", TREX, "-o", str(tmp_path / "a.spine.json"), "--tolerance", "-1"]) == 2
    assert "--tolerance" in capsys.readouterr().err
    assert main(["animate", TREX, "-o", str(tmp_path / "a.spine.json"), "--tolerance", "nan"]) == 2
    assert main(["animate", TREX, "-o", str(tmp_path / "a.html"), "--simplify", "1"]) == 2
    err = capsys.readouterr().err
    assert "--simplify does not apply to web player" in err and "only Spine takes it" in err
    assert main(["animate", TREX, "-o", str(tmp_path / "a.spine.json"), "--simplify", "0"]) == 2
    assert "--simplify" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []
    assert math.isclose(KEY_TOLERANCE, 1.0)


def barycentric(P: np.ndarray, V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(triangle, (p, 3) coordinates) of each point P in the mesh (V, F): the triangle
    that holds it, or the one it is least outside of."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]  # (t, 2)
    v0, v1 = b - a, c - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    v2 = P[:, None, :] - a[None]  # (p, t, 2)
    l1 = (v2[..., 0] * v1[None, :, 1] - v1[None, :, 0] * v2[..., 1]) / den
    l2 = (v0[None, :, 0] * v2[..., 1] - v2[..., 0] * v0[None, :, 1]) / den
    lam = np.stack([1 - l1 - l2, l1, l2], axis=2)
    t = np.argmax(lam.min(axis=2), axis=1)
    return t, lam[np.arange(len(P)), t]


def test_simplified_meshes_draw_every_frame_within_a_pixel(tmp_path):
    """``--simplify 0.5 --tolerance 0.5``: lighter meshes whose drawing, replayed as the
    runtimes interpolate, puts every vertex of puppet's own mesh (placed in the exported
    rest mesh) within 1 px of puppet's frame."""
    frames = []
    add = spine.SpineSink.add
    out, full = str(tmp_path / "s.spine.json"), str(tmp_path / "f.spine.json")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(spine.SpineSink, "add", lambda self, layers: (frames.append(layers), add(self, layers))[1])
        assert main(["animate", TREX, "-o", out, "--to", "1", "--simplify", "0.5", "--tolerance", "0.5"]) == 0
    assert main(["animate", TREX, "-o", full, "--to", "1", "--tolerance", "0.5"]) == 0
    with open(out) as f:
        doc = json.load(f)
    W, H = 600, 500
    atts = doc["skins"][0]["attachments"]
    timelines = doc["animations"]["animation"]["attachments"]["default"]
    fine = coarse = 0
    for i, L in enumerate(frames[0]):
        m = atts[L.name][L.name]
        setup = np.asarray(m["vertices"], float)
        V = np.stack([setup[0::2] + W / 2, H - setup[1::2]], 1)
        F = np.reshape(m["triangles"], (-1, 3))
        uv, h = np.reshape(m["uvs"], (-1, 2)), m["hull"]
        assert uv.min() >= 0 and uv.max() <= 1 and len(np.unique(F)) == len(V) == len(uv)  # a valid mesh
        assert {tuple(sorted((k, (k + 1) % h))) for k in range(h)} <= {tuple(sorted(e)) for e in
                                                                         boundary_edges(F).tolist()}
        tri, lam = barycentric(np.asarray(L.rest), V, F)
        corners = F[tri]
        fine, coarse = fine + len(L.rest), coarse + len(V)
        for f in range(len(frames)):
            v = replay_spine(timelines[L.name][L.name]["deform"], setup, f / 12).reshape(-1, 2) if L.name in timelines \
                else setup.reshape(-1, 2)
            drawn = np.stack([v[:, 0] + W / 2, H - v[:, 1]], 1)
            got = (drawn[corners] * lam[..., None]).sum(axis=1)
            err = np.linalg.norm(got - np.asarray(frames[f][i].deformed), axis=1).max()
            assert err < 1.0, (L.name, f, err)
    # lighter meshes (the T-rex's heads and front arm keep theirs: their outlines bend
    # more than 0.5 px between coarse outline vertices; measured 7943 -> 5277 since an
    # outline may not cut more than 0.45 px into a layer, 7814 -> 3718 before, when the
    # coarse meshes left edge pixels out)
    assert coarse < 0.7 * fine, (coarse, fine)
    # (the file: 0.99 of 1.40 MB, 0.70; 0.5 or so before)
    assert os.path.getsize(out) < 0.75 * os.path.getsize(full), (os.path.getsize(out), os.path.getsize(full))


def test_a_long_span_gets_a_key_every_span(monkeypatch):
    import puppet.anim.keys as keys

    monkeypatch.setattr(keys, "SPAN", 10)
    F, T = motion(lambda u: u, n=25)  # linear: only the ends and the cuts
    assert [k.frame for k in plan(F, T, [], 0.5)] == [0, 10, 20, 24]
