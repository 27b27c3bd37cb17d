"""Every deformer method, pin angles and exterior points, wired through a scene."""
import numpy as np
import pytest

import puppet
from puppet.cli import main
from puppet.geom.triangulate import signed_areas


def l_shape():
    """An L: a long bar and a block ("head") on its right end."""
    a = np.zeros((90, 160, 4), np.uint8)
    a[50:70, 10:150] = (60, 120, 200, 255)
    a[10:70, 110:150] = (60, 120, 200, 255)
    return a


def l_scene(method="arap", **extra):
    s = {"puppet": 1, "canvas": [160, 90], "background": [255, 255, 255, 255],
         "layers": [{"name": "L", "image": "l.png"}],
         "pins": [{"name": "foot", "layer": "L", "at": [15, 60]}, {"name": "mid", "layer": "L", "at": [70, 60]},
                  {"name": "head", "layer": "L", "at": [130, 30]}],
         "bones": [["foot", "mid"], ["mid", "head"]],
         "deformer": {"method": method},
         "poses": {"lift": {"head": [135, 15]}, "turn": {"head": {"angle": 30}}}}
    s.update(extra)
    return s


@pytest.mark.parametrize("method", ["arap", "igarashi", "mls", "mls-skeleton"])
def test_every_method_rest_pins_and_no_folds(make_scene, method):
    sc = puppet.load_scene(make_scene(l_scene(method), {"l.png": l_shape()}))
    (r,) = sc.layers()
    assert np.abs(r.deformed - r.rest).max() < 1e-9
    (r,) = sc.layers("lift")
    assert np.allclose(r.deformed[r.pins["head"]], [135, 15], atol=1e-9)
    assert np.allclose(r.deformed[r.pins["foot"]], [15, 60], atol=1e-9)
    assert (signed_areas(r.deformed, r.triangles) < 0).all()


def procrustes_angle(P, Q):
    """Best rotation P -> Q, degrees counter-clockwise on screen (y down)."""
    P = P - P.mean(0)
    Q = Q - Q.mean(0)
    a = (P * Q).sum()
    b = (P[:, 0] * Q[:, 1] - P[:, 1] * Q[:, 0]).sum()
    return -np.degrees(np.arctan2(b, a))  # raw (y down) angle -> on-screen angle


def test_pin_angle_turns_its_region(make_scene):
    sc = puppet.load_scene(make_scene(l_scene(), {"l.png": l_shape()}))
    (r,) = sc.layers("turn")
    near = np.linalg.norm(r.rest - [130, 30], axis=1) < 10
    ang = procrustes_angle(r.rest[near], r.deformed[near])
    assert abs(ang - 30) <= 6, ang
    right = near & (r.rest[:, 0] > 136)
    assert (r.deformed[right, 1] < r.rest[right, 1]).mean() > 0.9, "right of the pin moves up on screen"
    assert np.allclose(r.deformed[r.pins["head"]], [130, 30], atol=1e-9)


def test_skeleton_method_keeps_the_foot_still_when_the_head_moves(make_scene):
    sc = puppet.load_scene(make_scene(l_scene("mls-skeleton"), {"l.png": l_shape()}))
    (r,) = sc.layers("lift")
    foot = np.linalg.norm(r.rest - [15, 60], axis=1) < 8
    # the paper's range of an end pin is k (its bone + half the next), so the head's weight
    # ends about at the foot: the foot's far side stays, its near side may follow by a hair
    assert np.abs(r.deformed[foot] - r.rest[foot]).max() < 0.01 * np.hypot(5, 15)
    assert np.median(np.abs(r.deformed[foot] - r.rest[foot])) < 1e-6


def test_exterior_points_ride_along_and_pull_the_boundary(make_scene):
    s = l_scene(exterior=None)
    del s["exterior"]
    s["layers"][0]["exterior"] = {"auto": True, "beta": 3}
    s["pins"].append({"name": "tip", "layer": "L", "at": [149.5, 40], "kind": "exterior"})
    sc = puppet.load_scene(make_scene(s, {"l.png": l_shape()}))
    (r,) = sc.layers()
    names = sorted(r.exterior)
    assert "tip" in names and any(n.startswith("L:ext") for n in names)
    assert np.allclose(r.exterior["tip"], [149.5, 40], atol=1e-9)
    # a pose that moves only interior pins carries the exterior points along
    (r,) = sc.layers("lift")
    assert np.linalg.norm(np.array(r.exterior["tip"]) - [149.5, 40]) > 3
    # a pose that moves the exterior point pulls the nearby boundary, not the far end
    s["poses"]["bulge"] = {"tip": [158, 40]}
    sc = puppet.load_scene(make_scene(s, {"l.png": l_shape()}, name="b.json"))
    (r0,) = sc.layers()
    (r,) = sc.layers("bulge")
    k = int(np.argmin(np.linalg.norm(r0.rest - [149.5, 40], axis=1)))
    assert r.deformed[k, 0] - r0.rest[k, 0] > 0.5 * 8.5
    far = r0.rest[:, 0] < 60
    assert np.abs(r.deformed[far] - r0.rest[far]).max() < 0.2
    assert np.allclose(r.exterior["tip"], [158, 40])


def test_unknown_automatic_exterior_point_is_a_clear_error(make_scene, tmp_path, capsys):
    s = l_scene()
    s["layers"][0]["exterior"] = {"auto": True, "beta": 1}
    s["poses"]["bad"] = {"L:ext99": [1, 2]}
    path = make_scene(s, {"l.png": l_shape()})
    assert main(["check", path]) == 2
    err = capsys.readouterr().err
    assert "poses.bad.L:ext99" in err and "does not exist" in err
