"""What a joint or pin name says: a body part (``hand``, ``foot``, ``head``...) and a side.

Names are read in the conventions of motion capture files and of drawn characters alike:
``LeftHand``, ``mixamorig:LeftHand``, CMU's ``lhand`` / ``lfemur`` / ``ltibia`` / ``lfoot``,
``hand_l``, ``left_hand``, ``L_Hand``, ``hand.L``, ``foot_left``, ``fist``, ``hoof``. The
first part whose word appears in the name wins, in the order of :data:`PARTS` (so
``LeftHandIndex1`` is a finger, ``LeftForeArm`` an elbow, ``back_foot`` a foot). A side
is a word ``left``/``l``/``right``/``r`` of its own or CMU's one-letter prefix before a
part (``lhumerus``); ``hip`` with a side is a thigh (CMU's ``LeftHip``), without one the
pelvis.
"""
from __future__ import annotations

import re

__all__ = ["PARTS", "part_and_side"]

#: (part, words that name it), first match wins.
PARTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("finger", ("finger", "thumb", "index", "middle", "ring", "pinky")),
    ("toe", ("toe",)),
    ("foot", ("foot", "feet", "ankle", "shoe", "hoof", "boot", "paw")),
    ("hand", ("hand", "wrist", "fist", "palm", "claw")),
    ("elbow", ("forearm", "elbow", "radius", "lowerarm")),
    ("thigh", ("upleg", "thigh", "femur", "upperleg")),
    ("knee", ("knee", "leg", "shin", "tibia", "calf")),
    ("shoulder", ("shoulder", "clavicle", "collar", "humerus", "upperarm", "arm")),
    ("neck", ("neck",)),
    ("head", ("head", "skull", "snout", "face", "nose", "jaw", "mouth")),
    ("tail", ("tail",)),
    ("hip", ("hip", "pelvis", "root", "waist")),
    ("chest", ("chest", "thorax", "spine", "back", "torso", "body", "trunk", "belly")),
)
_WORDS = tuple(w for _, ws in PARTS for w in ws)


def _words(name: str) -> list[str]:
    name = name.rsplit(":", 1)[-1]  # mixamorig:LeftHand
    name = re.sub(r"([a-z0-9])([A-Z])", r"\1 \2", name)
    name = re.sub(r"([A-Z]+)([A-Z][a-z])", r"\1 \2", name)
    return [w for w in re.split(r"[^a-z0-9]+", name.lower()) if w]


def part_and_side(name: str) -> tuple[str | None, str | None]:
    """``(part, side)`` of a name: a part of :data:`PARTS` or None, ``"left"``,
    ``"right"`` or None."""
    words = _words(name)
    side = None
    for w in words:
        if w in ("left", "l", "lft") or (w.startswith("left") and len(w) > 4):
            side = "left"
        elif w in ("right", "r", "rt") or (w.startswith("right") and len(w) > 5):
            side = "right"
        elif w[:1] in "lr" and w[1:].startswith(_WORDS):  # CMU: lhand, rfemur, lhipjoint
            side = "left" if w[0] == "l" else "right"
    joined = "".join(words)
    for part, ws in PARTS:
        if any(x in joined for x in ws):
            if part == "hip" and side is not None:
                part = "thigh"
            return part, side
    return None, side
