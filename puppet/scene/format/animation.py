"""The scene file's ``animation`` section: keys of named poses (with pin ``overrides``)
or of inline pin targets, eases (``bezier`` with Spine-style control points), the
in-between and depth modes.

A compatible extension of format v1: a v1 animation (``fps`` and ``keys`` of ``time``,
``pose``, ``ease``) reads as before.
"""
from __future__ import annotations

from collections.abc import Callable

from puppet.scene.format import model as m
from puppet.scene.format.schema import (
    Ctx,
    expect_list,
    expect_number,
    expect_object,
    expect_string,
    join,
    short,
)

#: Largest |y| of a bezier ease's control points (overshoot beyond the keys is allowed).
MAX_CURVE_Y = 10.0
KEY_FIELDS = ("time", "pose", "pins", "overrides", "ease", "curve")

#: Two key times closer than this (seconds) are the same time.
SAME_TIME = 1e-9


def pins_json(pins: dict) -> dict:
    """A pins table in file form, numbers as floats (``[x, y]`` or ``{"to", "angle", "depth"}``;
    None, an override that leaves the pin out, stays None)."""
    out = {}
    for name, t in pins.items():
        if t is None:
            out[name] = None
        elif isinstance(t, dict):
            v = {k: ([float(t[k][0]), float(t[k][1])] if k == "to" else float(t[k]))
                 for k in ("to", "angle", "depth") if k in t and t[k] is not None}
            for k in t:
                if k not in ("to", "angle", "depth"):
                    v[k] = t[k]  # unknown fields are reported by the validation, with their path
            out[name] = v
        else:
            out[name] = [float(t[0]), float(t[1])]
    return out


def parse_animation(c: Ctx, v, p: str, poses: dict, parse_pins: Callable[[object, str], dict]) -> m.Animation:
    """Validate an ``animation`` object.

    Parameters
    ----------
    c : the scene file (for errors).
    v : the JSON value; p : its JSON path.
    poses : the scene's named poses (a key's ``pose`` must name one, or ``rest``).
    parse_pins : ``parse_pins(value, path) -> {name: Target}``, the checker of a pose table,
        used for a key's ``pins``.
    """
    expect_object(c, v, p, required=("keys",), optional=("fps", "keys", "inbetween", "depth"))
    fps = expect_number(c, v.get("fps", 24), join(p, "fps"), lo=0, lo_open=True, hi=240)
    inbetween = expect_string(c, v.get("inbetween", "rigid"), join(p, "inbetween"), choices=m.INBETWEENS)
    depth = expect_string(c, v.get("depth", "step"), join(p, "depth"), choices=m.DEPTH_MODES)
    kp = join(p, "keys")
    keys: list[m.Key] = []
    for i, k in enumerate(expect_list(c, v["keys"], kp, min_len=1)):
        key = parse_key(c, k, join(kp, i), poses, parse_pins)
        if keys and key.time < keys[-1].time:
            raise c.fail(join(join(kp, i), "time"),
                         f"keys must be sorted by time ({key.time:g} comes after {keys[-1].time:g})")
        keys.append(key)
    return m.Animation(fps=fps, keys=keys, inbetween=inbetween, depth=depth)


def parse_key(c: Ctx, k, q: str, poses: dict, parse_pins: Callable[[object, str], dict]) -> m.Key:
    """One key: ``{"time", "pose" | "pins", "overrides"? (with "pose"), "ease"?, "curve"?}``."""
    expect_object(c, k, q, required=("time",), optional=KEY_FIELDS)
    t = expect_number(c, k["time"], join(q, "time"), lo=0, hi=1e6)
    if ("pose" in k) == ("pins" in k):
        raise c.fail(q, "a key has exactly one of 'pose' (a pose name) and 'pins' (pin targets)")
    pose, pins, overrides = None, None, None
    if "pose" in k:
        pose = expect_string(c, k["pose"], join(q, "pose"))
        if pose != "rest" and pose not in poses:
            raise c.fail(join(q, "pose"), f"no pose named {short(pose)}")
        if "overrides" in k:
            overrides = parse_overrides(c, k["overrides"], join(q, "overrides"), parse_pins)
    else:
        if "overrides" in k:
            raise c.fail(join(q, "overrides"), "'overrides' go with a 'pose' key (a 'pins' key names its pins itself)")
        pins = parse_pins(k["pins"], join(q, "pins"))
    ease = expect_string(c, k.get("ease", "linear"), join(q, "ease"), choices=m.EASES)
    curve = None
    if ease == "bezier":
        if "curve" not in k:
            raise c.fail(join(q, "curve"), "a 'bezier' ease needs 'curve': [cx1, cy1, cx2, cy2]")
        cp = join(q, "curve")
        expect_list(c, k["curve"], cp, length=4)
        curve = tuple(expect_number(c, x, join(cp, j), lo=0 if j % 2 == 0 else -MAX_CURVE_Y,
                                    hi=1 if j % 2 == 0 else MAX_CURVE_Y)
                      for j, x in enumerate(k["curve"]))
    elif "curve" in k:
        raise c.fail(join(q, "curve"), f"'curve' belongs to the 'bezier' ease (this key's ease is {ease!r})")
    return m.Key(time=t, pose=pose, ease=ease, pins=pins, curve=curve, overrides=overrides)


def parse_overrides(c: Ctx, v, q: str, parse_pins: Callable[[object, str], dict]) -> dict:
    """A pose key's ``overrides``: pin name -> a target (as in a pose) that replaces the
    pose's for that pin, or ``null``: the key does not set that pin. ``{name: Target | None}``."""
    expect_object(c, v, q, optional=v.keys() if isinstance(v, dict) else ())
    free = [n for n, t in v.items() if t is None]
    out: dict = parse_pins({n: t for n, t in v.items() if t is not None}, q)
    parse_pins({n: [0, 0] for n in free}, q)  # the names of left-out pins are checked like any
    out.update({n: None for n in free})
    return out
