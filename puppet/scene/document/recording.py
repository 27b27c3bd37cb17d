"""Recorded motion written into an animation's keys without emptying its poses
(:meth:`puppet.scene.document.key_edits.KeyEdits.record_motion`).

Inside the recorded span the recorded pins must follow the recorded keys alone, and every
other pin must play as before. A pose key there stays a pose key, with ``overrides`` (a
compatible extension of the scene format): ``null`` for a recorded pin (the key leaves it
out, so its track passes straight from one recorded key to the next) or, when a recorded
key falls on the pose key's time, the recorded target. A pins key there loses the
recorded pins; recorded times with no key get a pins key of the recorded pins.
"""
from __future__ import annotations

import numpy as np

from puppet.scene.format.animation import SAME_TIME, pins_json


def recorded(s, keys: dict) -> dict[float, dict]:
    """The recorded keys in file form, a position-only target given the angle and depth
    the pin has at that time in the animation now: ``{time: {pin: target}}``.

    Raises SceneError for a name that is no pin or exterior point, or a bad time."""
    out: dict[float, dict] = {}
    interior = {p.name: i for i, p in enumerate(s.data.pins) if p.kind == "interior"}
    for t, pins in sorted(keys.items(), key=lambda kv: float(kv[0])):
        t = float(t)
        if not np.isfinite(t) or t < 0:
            raise s._fail(f"a recorded time must be a number >= 0, got {t}")
        for name in pins:
            s._check_target_name(name)
        table = pins_json(pins)
        state = s.state(time=t) if s.data.animation is not None else None
        for name, v in table.items():
            if isinstance(v, list) and state is not None and name in interior:
                i = interior[name]
                angle, depth = float(state.angle[i]), float(state.depth[i])
                if angle != 0.0 or depth != s.data.pins[i].depth:
                    table[name] = {"to": v, "angle": angle, "depth": depth}
        out[t] = table
    return out


def write_motion(doc: dict, table: dict[float, dict], lo: float, hi: float) -> None:
    """Change the scene JSON ``doc`` in place: the recorded ``table`` over ``lo``..``hi``."""
    names = {n for pins in table.values() for n in pins}
    anim = doc.setdefault("animation", {"fps": 24, "keys": []})
    keys = []
    for k in anim["keys"]:
        if lo <= k["time"] <= hi:
            if "pose" in k:
                k["overrides"] = {**k.get("overrides", {}), **{n: None for n in names}}
            else:
                k["pins"] = {n: v for n, v in k["pins"].items() if n not in names}
                if not k["pins"]:
                    continue
        keys.append(k)
    for t, pins in table.items():
        at = next((k for k in keys if abs(k["time"] - t) <= SAME_TIME), None)
        if at is None:
            keys.append({"time": t, "pins": dict(pins)})
        else:
            at.setdefault("overrides" if "pose" in at else "pins", {}).update(pins)
    anim["keys"] = sorted(keys, key=lambda k: k["time"])
