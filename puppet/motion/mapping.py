"""Which joint each pin follows: by name and by place, without a hand-written map.

Each pin and joint gets a part and a side from its name (:mod:`puppet.motion.names`).
The skeleton, projected (in the first frame used and in its HIERARCHY rest pose), is laid
over the pins: scaled to the same height, on the same bottom and x middle (the pins'
extent against that of the joints that have a part), then fitted again :data:`REFITS`
times along each axis to the pins it was matched with. A pin's cost for a joint is
their distance (in heights), plus :data:`PART_COST` where their parts differ (less for a
near part, :data:`_NEAR`), :data:`UNNAMED_COST` for a pin whose name says nothing
(``p3``), and :data:`SIDE_COST` where their named sides differ. The map is the
assignment of least total cost (Hungarian, one joint per pin) over both poses.

Sides are decided by place: a character facing the viewer has its left hand on the
screen's right, where the frontal projection puts the performer's left hand; a pin named
``hand_l`` drawn on the screen's left therefore follows ``RightHand``. Two pins of one
part on one side of the skeleton are split over both sides; the named side decides
where places do not (a profile, where both legs are drawn on top of each other).

A character in profile whose pins' names say nothing (``p0..p8``) has those pins' parts
found by their places (:func:`puppet.motion.project.parts_by_place`: feet lowest, head
highest, hip above the feet, chest on the line to the head, hands away from it, a tail
behind the hip), and they are mapped as if so named; of two hands or two feet so found,
the pin more to the screen's left follows the joint more to the left in the first pose.
"""
from __future__ import annotations

import json

import numpy as np
from scipy.optimize import linear_sum_assignment

from puppet.errors import SceneError
from puppet.motion.names import part_and_side
from puppet.motion.project import character_facing, parts_by_place

__all__ = ["auto_map", "read_map"]

#: Cost of a pin following a joint of another part (heights).
PART_COST = 1.0
#: Cost of a joint with no part, or a finger or toe, for a pin (heights).
MINOR_COST = 0.5
#: Cost of a named side against the other named side (heights).
SIDE_COST = 0.3
#: Times the skeleton is fitted again to the pins it was matched with (per-axis scale and move).
REFITS = 3
_NEAR = {frozenset({"hand", "finger"}): 0.5, frozenset({"foot", "toe"}): 0.5, frozenset({"head", "neck"}): 0.3,
         frozenset({"chest", "neck"}): 0.5, frozenset({"hip", "chest"}): 0.5}


def _laid_over(pins: np.ndarray, joints: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pins and joints in heights, bottoms and x middles together."""
    ref = joints[known] if known.any() else joints
    hp = max(float(np.ptp(pins[:, 1])), 1e-9)
    hj = max(float(np.ptp(ref[:, 1])), 1e-9)
    p = (pins - [0.5 * (pins[:, 0].min() + pins[:, 0].max()), pins[:, 1].max()]) / hp
    j = (joints - [0.5 * (ref[:, 0].min() + ref[:, 0].max()), ref[:, 1].max()]) / hj
    return p, j


#: Cost of a joint's part for a pin whose name says nothing (``p3``): the ends and the
#: trunk cost nothing, the middles of limbs a little, fingers, toes and unnamed joints more.
UNNAMED_COST = {"hand": 0.0, "foot": 0.0, "head": 0.0, "hip": 0.0, "chest": 0.0, "shoulder": 0.0,
                "elbow": 0.15, "knee": 0.15, "thigh": 0.15, "neck": 0.15}


def _refit(p: np.ndarray, q: np.ndarray, J: np.ndarray) -> np.ndarray:
    """``J`` scaled and moved along each axis so that the matched joints ``q`` come
    nearest (least squares) to their pins ``p`` (a character of other proportions: a big
    head, short legs)."""
    out = np.array(J, np.float64)
    for k in range(2):
        A = np.stack([q[:, k], np.ones(len(q))], axis=1)
        (a, b), *_ = np.linalg.lstsq(A, p[:, k], rcond=None)
        if a > 0.25:
            out[:, k] = a * J[:, k] + b
    return out


def _part_cost(pin: tuple, joint: tuple) -> float:
    (pp, ps), (jp, js) = pin, joint
    if pp is None:
        cost = UNNAMED_COST.get(jp, MINOR_COST)
    elif pp != jp:
        cost = _NEAR.get(frozenset({pp, jp}), PART_COST)
    else:
        cost = 0.0
    if ps is not None and js is not None and ps != js:
        cost += SIDE_COST
    return cost


def auto_map(pins: dict[str, np.ndarray], names: list[str], poses: list[np.ndarray], *,
             ends: list[bool] | None = None, root: int = 0, screen_left: float = 0.0,
             labels: dict[str, str] | None = None) -> dict[str, str]:
    """``{pin: joint}`` for pins ``{name: (x, y)}`` and joints ``names``, laid over the
    skeleton in each of ``poses`` (j, 2: projected places, y down; the pose whose
    assignment costs least is used). End Sites (``ends``) are not offered. A pin of a
    part no joint has (a ``tail``) follows joint ``root``. Where the projection's x runs
    along the performer's left (``screen_left`` > 0.7, the cosine) or right (< -0.7),
    a pin off the character's middle follows the joint of the side drawn there.
    ``labels`` ``{pin: layer name}``: a pin whose part is found by place takes the side its
    layer's name says (``p7`` on ``leftleg``)."""
    offered = [i for i in range(len(names)) if not (ends and ends[i])]
    jn = [names[i] for i in offered]
    pn = list(pins)
    P = np.array([pins[n] for n in pn], np.float64).reshape(-1, 2)
    jparts = [part_and_side(n) for n in jn]
    known = np.array([p not in (None, "finger", "toe") for p, _ in jparts])
    pparts, placed = _pin_parts(pins, labels or {})
    prior = np.array([[_part_cost(pparts[n], jp) for jp in jparts] for n in pn])
    best = None
    for pose in poses:
        p, j = _laid_over(P, np.asarray(pose, np.float64)[offered], known)
        for _ in range(REFITS + 1):
            cost = np.linalg.norm(p[:, None] - j[None], axis=2) + prior
            rows, cols = linear_sum_assignment(cost)
            total = float(cost[rows, cols].sum())
            if best is None or total < best[0] - 1e-12:
                best = (total, {pn[r]: jn[c] for r, c in zip(rows, cols)})
            j = _refit(p[rows], j[cols], j)
    out = best[1]
    have = {p for p, _ in jparts}
    for n in pn:
        pp = pparts[n][0]
        if pp is not None and pp not in have and not any(pp in pair and pair & have for pair in _NEAR):
            out[n] = names[root]
    if abs(screen_left) > 0.7:
        _sides_by_place(out, pins, jn, 1.0 if screen_left > 0 else -1.0)
    _both_sides(out, jn, pparts)
    unsided = {n: pparts[n][0] for n in placed if pparts[n][1] is None}
    _pairs_by_x(out, pins, unsided, {names[i]: float(poses[0][i][0]) for i in offered})
    return out


def _pin_parts(pins: dict[str, np.ndarray], labels: dict[str, str]) -> tuple[dict[str, tuple], set[str]]:
    """``({pin: (part, side)}, pins whose part was found by place)``: a character in
    profile whose pins' names say nothing (``p3``) has their parts found by place
    (:func:`puppet.motion.project.parts_by_place`), and their sides from their ``labels``
    (layer names: ``leftleg``); any other pin's part and side are its name's."""
    parts = {n: part_and_side(n) for n in pins}
    if all(p is not None for p, _ in parts.values()) or not character_facing(pins)[1]:
        return parts, set()
    found = parts_by_place(pins)
    placed = {n for n, (p, _) in parts.items() if p is None and found[n] is not None}
    parts.update({n: (found[n], parts[n][1] or part_and_side(labels.get(n, ""))[1]) for n in placed})
    return parts, placed


def _pairs_by_x(out: dict[str, str], pins, placed: dict[str, str], x: dict[str, float]) -> None:
    """Two pins of one part found by place with no side (``placed``: ``{pin: part}``; two
    hands, two feet) on joints of both sides: the pin more to the screen's left takes the joint more to
    the left in the first pose (``x``: the joints' screen x), so that the foot drawn in front
    follows the foot the clip puts in front."""
    for part in ("hand", "foot"):
        two = [p for p, pp in placed.items() if pp == part]
        if len(two) != 2:
            continue
        a, b = sorted(two, key=lambda p: float(pins[p][0]))
        ja, jb = out.get(a), out.get(b)
        if ja in x and jb in x and {part_and_side(ja)[1], part_and_side(jb)[1]} == {"left", "right"} and x[ja] > x[jb]:
            out[a], out[b] = jb, ja


def _take(out: dict[str, str], pin: str, joint: str) -> None:
    """Give ``pin`` ``joint``; its former owner (if any) gets the pin's old joint."""
    owner = next((q for q, j in out.items() if j == joint), None)
    if owner is not None:
        out[owner] = out[pin]
    out[pin] = joint


def _both_sides(out: dict[str, str], names: list[str], parts: dict[str, tuple]) -> None:
    """Two pins of one part (``parts``: ``{pin: (part, side)}``; two hands of a character
    in profile) on one side of the skeleton: the second takes the other side's joint."""
    seen: dict[tuple, str] = {}
    for pin in list(out):
        part, side = part_and_side(out[pin])
        if side is None or part is None:
            continue
        if (part, side) in seen and parts[seen[(part, side)]][0] == parts[pin][0]:
            other = _mirror(out[pin], names)
            if other is not None:
                _take(out, pin, other)
                part, side = part_and_side(other)
        seen[(part, side)] = pin


def _mirror(joint: str, names: list[str]) -> str | None:
    """The joint of the other side with the same name otherwise (``LeftHand`` ->
    ``RightHand``, ``lhand`` -> ``rhand``, ``hand_l`` -> ``hand_r``)."""
    part, side = part_and_side(joint)
    swaps = [("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT"), ("L", "R"), ("l", "r")]
    for a, b in swaps:
        if side == "right":
            a, b = b, a
        for cand in (joint.replace(a, b, 1), joint[::-1].replace(a[::-1], b[::-1], 1)[::-1]):
            if cand != joint and cand in names and part_and_side(cand) == (part, "right" if side == "left" else "left"):
                return cand
    return None


def _sides_by_place(out: dict[str, str], pins, names: list[str], sign: float) -> None:
    """Give each pin off the middle (the pins' mean x, by more than 5% of their height)
    the joint of the side drawn there: x * ``sign`` > 0 is the performer's left."""
    P = np.array(list(pins.values()), np.float64)
    mid, band = float(P[:, 0].mean()), 0.05 * max(float(np.ptp(P[:, 1])), 1.0)
    for pin in list(out):
        joint = out[pin]
        side = part_and_side(joint)[1]
        dx = (float(pins[pin][0]) - mid) * sign
        if side is None or abs(dx) <= band or (side == "left") == (dx > 0):
            continue
        other = _mirror(joint, names)
        if other is not None:
            _take(out, pin, other)


def read_map(path: str, pins: list[str], joints: list[str]) -> dict[str, str]:
    """A map file ``{"PIN": "JOINT"}``: every name checked against the scene's pins and the
    motion's joints (one line naming the file and the name where one is unknown)."""
    try:
        with open(path, encoding="utf-8") as f:
            raw = json.load(f)
    except OSError as e:
        raise SceneError(f"cannot read: {e.strerror or e}", file=path) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise SceneError(f"not JSON: {e}".splitlines()[0], file=path) from None
    if not isinstance(raw, dict) or not raw or not all(isinstance(v, str) for v in raw.values()):
        raise SceneError('a map is an object {"PIN": "JOINT", ...} with at least one pin', file=path)
    for pin, joint in raw.items():
        if pin not in pins:
            raise SceneError(f"no pin named {pin!r} in the scene (pins: {', '.join(pins)})", file=path)
        if joint not in joints:
            raise SceneError(f"{pin}: no joint named {joint!r} in the motion", file=path)
    return dict(raw)
