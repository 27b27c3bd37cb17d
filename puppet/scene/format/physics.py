"""The scene file's ``physics`` section (a compatible extension of format v1): chains of
pins with secondary motion.

``"physics": {"chains": [{"pins": ["sleeve_root", "sleeve_mid", "sleeve_end"],
"frequency": 2.0, "damping": 0.3, "gravity": 0.0}]}``. The first pin of a chain follows
the animation; each later one follows its animated place through a damped spring
(:mod:`puppet.scene.time.physics`).
"""
from __future__ import annotations

from puppet.scene.format import model as m
from puppet.scene.format.schema import Ctx, expect_list, expect_number, expect_object, expect_string, join, short

#: Highest natural frequency (Hz): the internal step (1/240 s) resolves it.
MAX_FREQUENCY = 30.0
#: Largest damping ratio and |gravity| (px/s^2).
MAX_DAMPING, MAX_GRAVITY = 10.0, 1e5
CHAIN_FIELDS = ("pins", "frequency", "damping", "gravity")


def parse_physics(c: Ctx, v, p: str, pins: list[m.Pin]) -> list[m.Chain]:
    """The chains of ``physics`` at JSON path ``p``; refused in one line each: an unknown
    or non-interior pin, a pin named twice, a chain of fewer than 2 pins, a value out of
    range."""
    expect_object(c, v, p, required=("chains",))
    kinds = {q.name: q.kind for q in pins}
    chains, owner = [], {}
    for i, ch in enumerate(expect_list(c, v["chains"], join(p, "chains"))):
        cp = join(join(p, "chains"), i)
        expect_object(c, ch, cp, required=("pins",), optional=CHAIN_FIELDS)
        names = expect_list(c, ch["pins"], join(cp, "pins"), min_len=2)
        for j, nm in enumerate(names):
            q = join(join(cp, "pins"), j)
            nm = expect_string(c, nm, q)
            if nm not in kinds:
                raise c.fail(q, f"no pin named {short(nm)}")
            if kinds[nm] != "interior":
                raise c.fail(q, f"pin {short(nm)} is {kinds[nm]}: a chain moves interior pins only")
            if nm in owner:
                raise c.fail(q, f"pin {short(nm)} is in a chain already ({owner[nm]})")
            owner[nm] = cp
        d = m.Chain(pins=())
        chains.append(m.Chain(
            pins=tuple(names),
            frequency=expect_number(c, ch.get("frequency", d.frequency), join(cp, "frequency"), lo=0, lo_open=True,
                                    hi=MAX_FREQUENCY),
            damping=expect_number(c, ch.get("damping", d.damping), join(cp, "damping"), lo=0, hi=MAX_DAMPING),
            gravity=expect_number(c, ch.get("gravity", d.gravity), join(cp, "gravity"), lo=-MAX_GRAVITY,
                                  hi=MAX_GRAVITY)))
    return chains


def raw_chains(doc: dict) -> list[dict]:
    """The scene JSON's physics chains as written (none without ``physics``)."""
    physics = doc.get("physics")
    return physics.get("chains", []) if isinstance(physics, dict) else []


def drop_chain_pins(doc: dict, dropped) -> None:
    """Take the pins for which ``dropped(name)`` holds out of the scene JSON's chains (a
    pin removed, or gone with its layer); a chain left with one pin goes."""
    if raw_chains(doc):
        chains = [dict(ch, pins=[x for x in ch["pins"] if not dropped(x)]) for ch in raw_chains(doc)]
        doc["physics"] = dict(doc["physics"], chains=[ch for ch in chains if len(ch["pins"]) >= 2])
