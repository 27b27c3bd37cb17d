"""BVH motion capture files: the joint tree (HIERARCHY) and its channels per frame (MOTION),
and forward kinematics to world joint positions for every frame at once.

A joint's rotation channels are applied in the order the file lists them, each about its
own (rotated) axis, in degrees: ``CHANNELS 3 Zrotation Xrotation Yrotation`` makes
``R = Rz(z) Rx(x) Ry(y)``, the convention of the BVH format (Biovision) and of Blender's
and MotionBuilder's readers. A joint's position channels give its translation from its
parent in the parent's frame, replacing the OFFSET's component on each axis they name
(the root's usual ``Xposition Yposition Zposition``; exporters that write six channels on
every joint write the offsets there). A world position is
``P_parent + R_parent (offset + translation)`` and a world rotation ``R_parent R_local``.

An ``End Site`` is a joint with no channels named ``<parent>_end``: the tip of a head,
a hand, a foot.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from puppet.errors import SceneError

__all__ = ["Joint", "Motion", "parse_bvh", "read_bvh", "rotation_matrices"]

#: Largest BVH file read (bytes): a 10 minute clip at 120 fps of 100 channels is ~50 MB.
MAX_BYTES = 200 * 1024 * 1024
_AXES = {"X": 0, "Y": 1, "Z": 2}
_CHANNELS = {f"{a}{kind}" for a in "XYZ" for kind in ("position", "rotation")}


@dataclass(frozen=True)
class Joint:
    """One joint: its name, parent index (-1: a root), OFFSET (3,), its channels in file
    order (``Zrotation``...), and whether it is an End Site."""

    name: str
    parent: int
    offset: tuple[float, float, float]
    channels: tuple[str, ...]
    end: bool = False


@dataclass(frozen=True)
class Motion:
    """A BVH file read: ``joints`` parents first, ``frame_time`` seconds, ``values``
    (frames, channels) in the file's column order, ``file`` for messages."""

    joints: tuple[Joint, ...]
    frame_time: float
    values: np.ndarray
    file: str

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def count(self) -> int:
        return int(self.values.shape[0])

    @property
    def times(self) -> np.ndarray:
        """Each frame's time (frames,), seconds from the first."""
        return np.arange(self.count) * self.frame_time

    def columns(self) -> list[slice]:
        """Each joint's columns of :attr:`values`."""
        out, c = [], 0
        for j in self.joints:
            out.append(slice(c, c + len(j.channels)))
            c += len(j.channels)
        return out

    def positions(self, frames: np.ndarray | slice | None = None) -> np.ndarray:
        """World positions (frames, joints, 3) of the frames asked (default all)."""
        V = self.values if frames is None else self.values[frames]
        return _forward(self.joints, self.columns(), np.atleast_2d(V))

    def rest(self) -> np.ndarray:
        """World positions (joints, 3) with every channel at 0 and translations at their
        offsets: the skeleton as the HIERARCHY draws it."""
        V = np.zeros((1, self.values.shape[1]))
        for j, cols in zip(self.joints, self.columns()):
            for c, ch in zip(range(cols.start, cols.stop), j.channels):
                if ch.endswith("position"):
                    V[0, c] = j.offset[_AXES[ch[0]]]
        return _forward(self.joints, self.columns(), V)[0]


def rotation_matrices(axis: str, degrees: np.ndarray) -> np.ndarray:
    """Right-handed rotations (n, 3, 3) about ``axis`` ("X", "Y" or "Z") by ``degrees`` (n,)."""
    a = np.radians(np.asarray(degrees, np.float64))
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i = _AXES[axis]
    j, k = (i + 1) % 3, (i + 2) % 3
    R[..., i, i] = 1.0
    R[..., j, j] = c
    R[..., k, k] = c
    R[..., j, k] = -s
    R[..., k, j] = s
    return R


def _forward(joints, columns, V: np.ndarray) -> np.ndarray:
    n = V.shape[0]
    P = np.zeros((n, len(joints), 3))
    R = np.empty((n, len(joints), 3, 3))
    for ji, (j, cols) in enumerate(zip(joints, columns)):
        t = np.broadcast_to(np.asarray(j.offset, np.float64), (n, 3)).copy()
        Rl = np.broadcast_to(np.eye(3), (n, 3, 3))
        for c, ch in zip(range(cols.start, cols.stop), j.channels):
            if ch.endswith("position"):
                t[:, _AXES[ch[0]]] = V[:, c]
            else:
                Rl = Rl @ rotation_matrices(ch[0], V[:, c])
        if j.parent < 0:
            P[:, ji], R[:, ji] = t, Rl
        else:
            Rp = R[:, j.parent]
            P[:, ji] = P[:, j.parent] + np.einsum("fab,fb->fa", Rp, t)
            R[:, ji] = Rp @ Rl
    return P


def read_bvh(path: str | os.PathLike) -> Motion:
    """Read a BVH file; :class:`SceneError` naming the file and line where it is not one."""
    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
        if size > MAX_BYTES:
            raise SceneError(f"{size} bytes: larger than the {MAX_BYTES} read", file=path)
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError as e:
        raise SceneError(f"cannot read: {e.strerror or e}", file=path) from None
    return parse_bvh(text, file=path)


class _Tokens:
    """The hierarchy's words with their line numbers."""

    def __init__(self, lines: list[str], file: str):
        self.lines, self.file = lines, file
        self.row, self.words = -1, []

    def fail(self, what: str, row: int | None = None):
        raise SceneError(f"line {(self.row if row is None else row) + 1}: {what}", file=self.file)

    def next(self, what: str) -> str:
        while not self.words:
            if self.row + 1 >= len(self.lines):
                self.fail(f"the file ends where {what} was expected", max(len(self.lines) - 1, 0))
            self.row += 1
            self.words = self.lines[self.row].split()
        return self.words.pop(0)

    def number(self, what: str) -> float:
        w = self.next(what)
        try:
            v = float(w)
        except ValueError:
            v = math.nan
        if not math.isfinite(v):
            self.fail(f"{what}: {w!r} is not a number")
        return v

    def expect(self, word: str) -> None:
        w = self.next(repr(word))
        if w != word:
            self.fail(f"{word!r} expected, found {w!r}")


def parse_bvh(text: str, *, file: str = "<bvh>") -> Motion:
    """The :class:`Motion` of a BVH text."""
    lines = text.splitlines()
    tok = _Tokens(lines, file)
    tok.expect("HIERARCHY")
    joints: list[Joint] = []
    word = tok.next("ROOT")
    if word != "ROOT":
        tok.fail(f"'ROOT' expected, found {word!r}")
    while word == "ROOT":
        _joint(tok, joints, -1)
        word = tok.next("MOTION")
    if word != "MOTION":
        tok.fail(f"'MOTION' or 'ROOT' expected, found {word!r}")
    tok.expect("Frames:")
    frames = tok.number("the frame count")
    if frames != int(frames) or frames < 0:
        tok.fail(f"Frames: {frames:g} is not a count")
    tok.expect("Frame")
    tok.expect("Time:")
    dt = tok.number("the frame time")
    if dt <= 0:
        tok.fail(f"Frame Time: {dt:g} is not a positive number of seconds")
    if tok.words:
        tok.fail(f"{tok.words[0]!r} after the frame time")
    width = sum(len(j.channels) for j in joints)
    values = _rows(lines, tok.row + 1, int(frames), width, file)
    return Motion(tuple(joints), float(dt), values, file)


def _joint(tok: _Tokens, joints: list[Joint], parent: int) -> None:
    """Read one ROOT/JOINT block (its keyword already read) and its children, iteratively."""
    stack: list[int] = []
    pending = (tok.next("a joint name"), parent, False)
    while True:
        name, par, end = pending
        row = tok.row
        tok.expect("{")
        tok.expect("OFFSET")
        offset = tuple(tok.number("an OFFSET value") for _ in range(3))
        channels: tuple[str, ...] = ()
        word = tok.next("'}'")
        if word == "CHANNELS":
            if end:
                tok.fail("an End Site has no CHANNELS")
            channels = _channels(tok)
            word = tok.next("'}'")
        if name in (j.name for j in joints):
            tok.fail(f"joint {name!r} is named twice", row)
        joints.append(Joint(name, par, offset, channels, end))  # type: ignore[arg-type]
        stack.append(len(joints) - 1)
        pending = None
        while pending is None:
            if word == "JOINT" and not joints[stack[-1]].end:
                pending = (tok.next("a joint name"), stack[-1], False)
            elif word == "End" and not joints[stack[-1]].end:
                tok.expect("Site")
                pending = (_end_name(joints, stack[-1]), stack[-1], True)
            elif word == "}":
                stack.pop()
                if not stack:
                    return
                word = tok.next("'}'")
            else:
                tok.fail(f"'JOINT', 'End Site' or '}}' expected, found {word!r}")


def _end_name(joints: list[Joint], parent: int) -> str:
    base = f"{joints[parent].name}_end"
    name, i = base, 2
    while name in (j.name for j in joints):
        name, i = f"{base}{i}", i + 1
    return name


def _channels(tok: _Tokens) -> tuple[str, ...]:
    n = tok.number("the channel count")
    if n != int(n) or not 0 <= n <= 6:
        tok.fail(f"CHANNELS {n:g}: a count from 0 to 6 expected")
    out = tuple(tok.next("a channel") for _ in range(int(n)))
    for ch in out:
        if ch not in _CHANNELS:
            tok.fail(f"unknown channel {ch!r} (Xposition ... Zrotation)")
    if len(set(out)) < len(out):
        tok.fail(f"a channel is named twice in {' '.join(out)}")
    return out


def _rows(lines: list[str], first: int, frames: int, width: int, file: str) -> np.ndarray:
    """The MOTION rows: ``frames`` lines of ``width`` numbers from line ``first``."""
    body = [(i, line) for i, line in enumerate(lines[first:], first) if line.strip()]
    if len(body) != frames:
        where = body[frames][0] + 1 if len(body) > frames else len(lines)
        raise SceneError(f"line {where}: Frames: {frames} declared, {len(body)} rows of values found", file=file)
    out = np.empty((frames, width))
    for r, (i, line) in enumerate(body):
        words = line.split()
        if len(words) != width:
            raise SceneError(f"line {i + 1}: {len(words)} values, {width} channels declared", file=file)
        try:
            out[r] = [float(w) for w in words]
        except ValueError:
            bad = next(w for w in words if not _is_float(w))
            raise SceneError(f"line {i + 1}: {bad!r} is not a number", file=file) from None
    if not np.isfinite(out).all():
        i = body[int(np.flatnonzero(~np.isfinite(out).all(axis=1))[0])][0]
        raise SceneError(f"line {i + 1}: a value is not finite", file=file)
    return out


def _is_float(w: str) -> bool:
    try:
        float(w)
        return True
    except ValueError:
        return False
