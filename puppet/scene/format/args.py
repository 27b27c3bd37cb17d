"""The Python API's argument checks: what each argument of a public method must be.

Every public method of a scene (:class:`puppet.api.Scene`, the
:class:`~puppet.scene.document.core.Document` it extends, a drag session) is wrapped by
:func:`checked`, which names a check for each of its arguments. A value that is not what
the check asks for raises one :class:`~puppet.errors.SceneError` naming the scene file,
the method and the argument::

    scene.json: drag: size must be two whole numbers 1..16384 of at most 67108864 pixels, got (0, 0)

before the method runs, so nothing has changed and nothing is written. A check returns
the value converted to what the method works with (floats, ints, ``(h, w)`` arrays,
``str`` paths), so the method never meets a string where it wants a number, NaN, a
``bool`` where it counts, or an array of the wrong shape. Values in scene-format form
(a mask, a pins table, deformer options) are checked here for their kind only (plain
data: dicts, lists, strings, finite numbers); their meaning is checked by the scene's
validator (:func:`puppet.scene.format.load.parse_scene`), which every edit runs before
it takes effect, and whose errors name the JSON path.

The limits are the format's: coordinates within :data:`~puppet.scene.format.schema.MAX_COORD`,
output sizes within :data:`puppet.imaging.io.MAX_SIDE` a side and
:data:`puppet.imaging.io.MAX_PIXELS` in all.
"""
from __future__ import annotations

import functools
import inspect
import math
import numbers
import os
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import MAX_PIXELS, MAX_SIDE
from puppet.scene.format.reader import MAX_DEPTH, MAX_INT
from puppet.scene.format.schema import MAX_COORD, short

#: Largest value of an iteration count (the format's ``deformer.iterations``).
MAX_ITERATIONS = 10000
#: Largest animation time, seconds (the format's key times).
MAX_TIME = 1e6


class Arg:
    """The argument being checked: which method of which owner, its name, and the other
    arguments of the call (already checked when their checks come first)."""

    def __init__(self, owner, method: str, name: str, args: Mapping):
        self.owner, self.method, self.name, self.args = owner, method, name, args

    def fail(self, must: str, got: Any = None, *, show: bool = True) -> SceneError:
        """``METHOD: NAME must MUST, got GOT``, naming the owner's scene file."""
        tail = f", got {describe(got)}" if show else ""
        return SceneError(f"{self.method}: {self.name} must {must}{tail}", file=_file_of(self.owner, self.args))


Check = Callable[[Any, Arg], Any]


def _file_of(owner, args: Mapping | None = None) -> str | None:
    """The scene file to name: the owner's, a drag session's document's, or (a drag
    session being made) that of its ``doc`` or ``scene`` argument."""
    args = args or {}
    for doc in (getattr(owner, "doc", None), args.get("doc"), args.get("scene"), owner):
        file = getattr(doc, "file", None)
        if isinstance(file, str):
            return file
    return None


def describe(v: Any) -> str:
    """A short words-and-value form of ``v`` for a message."""
    if isinstance(v, np.ndarray):
        return f"an array of shape {v.shape} and type {v.dtype}"
    if isinstance(v, str):
        return f"the string {short(v)}"
    try:
        text = repr(v)
    except Exception:  # noqa: BLE001 (a user's object whose repr fails is still named)
        text = f"a {type(v).__name__}"
    text = " ".join(text.split()) if "\n" in text else text  # one line: an array's repr has several
    return text if len(text) <= 60 else text[:57] + "..."


def checked(_name: str | None = None, /, **checks: Check):
    """Decorate a method: each named argument is passed through its check (in the order
    given) before the method runs; a call that does not fit the signature is a
    SceneError too. ``_name`` names the method in messages (default: its own name; a
    class for its ``__init__``). The wrapper carries ``__checks__`` (the names checked)."""
    def wrap(fn):
        name = _name or fn.__name__
        sig = inspect.signature(fn)
        unknown = set(checks) - set(sig.parameters)
        if unknown:
            raise TypeError(f"{fn.__qualname__} has no argument {sorted(unknown)}")

        @functools.wraps(fn)
        def method(self, *args, **kwargs):
            try:
                bound = sig.bind(self, *args, **kwargs)
            except TypeError as e:
                raise SceneError(f"{name}: {e}", file=_file_of(self)) from None
            values = bound.arguments
            for arg, check in checks.items():
                if arg in values:
                    values[arg] = check(values[arg], Arg(self, name, arg, values))
            return fn(*bound.args, **bound.kwargs)
        method.__checks__ = tuple(checks)
        return method
    return wrap


# -- checks ----------------------------------------------------------------------------
def anything(v, a: Arg):
    """No check (the method accepts every value, or checks it itself with a SceneError)."""
    return v


def optional(check: Check) -> Check:
    """None, or what ``check`` accepts."""
    def opt(v, a: Arg):
        return None if v is None else check(v, a)
    return opt


def _is_real(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def number(lo: float = -MAX_COORD, hi: float = MAX_COORD, *, lo_open: bool = False) -> Check:
    """A finite real number (not a bool) in [lo, hi] (``(lo, hi]`` with ``lo_open``), as float."""
    must = f"be a number {'>' if lo_open else '>='} {lo:g} and <= {hi:g}"

    def num(v, a: Arg) -> float:
        try:
            x = float(v) if _is_real(v) else math.nan
        except OverflowError:  # an int beyond a float
            x = math.inf
        if not math.isfinite(x) or x < lo or (lo_open and x == lo) or x > hi:
            raise a.fail(must, v)
        return x
    return num


def integer(lo: int, hi: int) -> Check:
    """A whole number (an int, not a bool) in [lo, hi], as int."""
    def whole(v, a: Arg) -> int:
        if not isinstance(v, numbers.Integral) or isinstance(v, (bool, np.bool_)) or not lo <= int(v) <= hi:
            raise a.fail(f"be a whole number {lo}..{hi}", v)
        return int(v)
    return whole


def flag(v, a: Arg) -> bool:
    """True or False (numpy's bools too)."""
    if not isinstance(v, (bool, np.bool_)):
        raise a.fail("be True or False", v)
    return bool(v)


def text(v, a: Arg) -> str:
    """A non-empty string (a name of a pin, layer, pose; an ease; a label)."""
    if not isinstance(v, str) or not v:
        raise a.fail("be a non-empty string", v)
    return v


def texts(v, a: Arg) -> list[str]:
    """One name, or a non-empty list of names."""
    if isinstance(v, str):
        return [text(v, a)]
    if not isinstance(v, (list, tuple)) or not v or not all(isinstance(x, str) and x for x in v):
        raise a.fail("be a name or a list of at least one name", v)
    return list(v)


def path(v, a: Arg) -> str:
    """A file path: a non-empty ``str`` or ``os.PathLike`` of one, without NUL characters."""
    try:
        p = os.fspath(v)
    except TypeError:
        p = None
    if not isinstance(p, str) or not p or "\0" in p:
        raise a.fail("be a file path (a non-empty string or path-like)", v)
    return p


def _numeric(v, ndim: int | None = None) -> np.ndarray | None:
    """``v`` as a float array when it is numbers (not bools, strings or objects), else None."""
    if isinstance(v, (str, bytes, Mapping)) or v is None:
        return None
    try:
        arr = np.asarray(v)
    except (TypeError, ValueError, OverflowError):  # ragged lists, huge ints
        return None
    if arr.dtype.kind not in "iuf" or (ndim is not None and arr.ndim != ndim):
        return None
    try:
        return arr.astype(np.float64)
    except (TypeError, ValueError, OverflowError):
        return None


def point(v, a: Arg) -> list[float]:
    """A canvas point: two finite numbers within +-MAX_COORD, as ``[x, y]`` floats."""
    arr = _numeric(v, 1)
    if arr is None or arr.shape != (2,) or not np.all(np.isfinite(arr)) or np.any(np.abs(arr) > MAX_COORD):
        raise a.fail(f"be two finite numbers (x, y) within +-{MAX_COORD:g}", v)
    return [float(arr[0]), float(arr[1])]


def points(min_len: int, max_len: int | None = None) -> Check:
    """A list of ``min_len`` (to ``max_len``) canvas points, as ``[[x, y], ...]`` floats."""
    count = f"at least {min_len}" if max_len is None else f"{min_len}" if max_len == min_len else \
        f"{min_len}..{max_len}"

    def pts(v, a: Arg) -> list[list[float]]:
        arr = _numeric(v, 2)
        if (arr is None or arr.shape[1:] != (2,) or len(arr) < min_len or max_len is not None and len(arr) > max_len
                or not np.all(np.isfinite(arr)) or np.any(np.abs(arr) > MAX_COORD)):
            raise a.fail(f"be {count} points [x, y] of finite numbers within +-{MAX_COORD:g}", v)
        return arr.tolist()
    return pts


def size(v, a: Arg) -> tuple[int, int]:
    """An output size (width, height): whole numbers 1..MAX_SIDE, at most MAX_PIXELS in all."""
    must = f"be two whole numbers 1..{MAX_SIDE} of at most {MAX_PIXELS} pixels"
    if isinstance(v, np.ndarray) and v.ndim == 1:
        v = tuple(v.tolist())
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise a.fail(must, v)
    w, h = v[0], v[1]
    for x in (w, h):
        if not isinstance(x, numbers.Integral) or isinstance(x, (bool, np.bool_)) or not 1 <= int(x) <= MAX_SIDE:
            raise a.fail(must, tuple(v))
    if int(w) * int(h) > MAX_PIXELS:
        raise a.fail(must, tuple(v))
    return (int(w), int(h))


def pixels(kind: str, channels: int | None = None, *, lo: float = 0, hi: float = 255) -> Check:
    """An image array for ``kind`` (words in the message): (h, w) when ``channels`` is
    None, else (h, w, channels); finite numbers lo..hi (bools count as 0 and 1); sides
    1..MAX_SIDE and at most MAX_PIXELS. Returned as given when an array, else as a float array."""
    shape = "(h, w)" if channels is None else f"(h, w, {channels})"
    must = f"be {kind}: an {shape} array of numbers {lo:g}..{hi:g}"

    def pix(v, a: Arg) -> np.ndarray:
        if isinstance(v, np.ndarray) and v.dtype == np.bool_:
            arr = v
        else:
            arr = _numeric(v)
        ndim = 2 if channels is None else 3
        if arr is None or arr.ndim != ndim or (channels is not None and arr.shape[2] != channels):
            raise a.fail(must, v)
        h, w = arr.shape[:2]
        if not (1 <= h <= MAX_SIDE and 1 <= w <= MAX_SIDE and h * w <= MAX_PIXELS):
            raise a.fail(f"be {kind} of 1..{MAX_SIDE} pixels a side and at most {MAX_PIXELS} pixels", v)
        if arr.dtype != np.bool_ and (not np.all(np.isfinite(arr)) or arr.min() < lo or arr.max() > hi):
            raise a.fail(f"hold finite numbers {lo:g}..{hi:g} only", v)
        return v if isinstance(v, np.ndarray) else arr
    return pix


def layer_grid(check: Check, layer_arg: str = "name") -> Check:
    """``check``, then the array must have the (h, w) of the image grid of the layer named
    by argument ``layer_arg`` (its own image, or the source for a layer without one)."""
    def grid(v, a: Arg) -> np.ndarray:
        arr = check(v, a)
        doc = a.owner
        names = [L.name for L in doc.data.layers]
        layer = a.args.get(layer_arg)
        if layer not in names:
            raise SceneError(f"{a.method}: no layer named {short(layer)}", file=_file_of(doc))
        hw = doc.built.images[names.index(layer)].mask.shape[:2]
        if arr.shape[:2] != hw:
            raise a.fail(f"be the size of the image of layer {layer!r}, (h, w) = {hw}", v)
        return arr
    return grid


def plain(v, a: Arg):
    """Scene-format data: dicts with string keys, lists (tuples become lists), strings,
    finite numbers (numpy's become Python's), bools and None, nested at most MAX_DEPTH
    deep. What the value means is checked by the scene's validator."""
    def conv(x, depth: int):
        if depth > MAX_DEPTH:
            raise a.fail(f"be nested at most {MAX_DEPTH} levels deep", show=False)
        if x is None or isinstance(x, (bool, str)):
            return x
        if isinstance(x, np.bool_):
            return bool(x)
        if _is_real(x):
            if isinstance(x, numbers.Integral):
                if abs(int(x)) > MAX_INT:  # as the file reader: every integer exact as a float
                    raise a.fail("hold whole numbers within +-2^53 only", x)
                return int(x)
            try:
                f = float(x)
            except OverflowError:
                f = math.inf
            if not math.isfinite(f):
                raise a.fail("hold finite numbers only", x)
            return f
        if isinstance(x, Mapping):
            if not all(isinstance(k, str) for k in x):
                raise a.fail("have string keys only", list(x))
            return {k: conv(y, depth + 1) for k, y in x.items()}
        if isinstance(x, (list, tuple)):
            return [conv(y, depth + 1) for y in x]
        if isinstance(x, np.ndarray) and x.ndim >= 1:
            return [conv(y, depth + 1) for y in x.tolist()]
        raise a.fail("be scene-format data (objects, lists, strings, numbers, true/false, null)", x)
    return conv(v, 0)


def target(v, a: Arg):
    """A pin target in file form: ``[x, y]`` or ``{"to": [x, y], "angle": deg, "depth": d}``
    (plain data; the validator checks the fields)."""
    if isinstance(v, Mapping):
        t = plain(v, a)
        if t.get("to") is not None:
            t["to"] = point(t["to"], a)
        for k in ("angle", "depth"):
            if t.get(k) is not None:
                t[k] = COORD(t[k], a)
        return t
    return point(v, a)


def pins_table(*, nulls: bool = False) -> Check:
    """``{pin: target}`` (:func:`target`); with ``nulls``, None for a pin left out."""
    def table(v, a: Arg) -> dict:
        if not isinstance(v, Mapping) or not all(isinstance(k, str) and k for k in v):
            raise a.fail("be a dict of pin names to targets", v)
        return {k: (None if t is None and nulls else target(t, a)) for k, t in v.items()}
    return table


def timed_tables(v, a: Arg) -> dict:
    """``{time: {pin: target}}``: recorded keys."""
    if not isinstance(v, Mapping):
        raise a.fail("be a dict of times to {pin: target} tables", v)
    t, table = number(0, MAX_TIME), pins_table()
    at = Arg(a.owner, a.method, f"a time in {a.name}", a.args)
    return {t(k, at): table(p, a) for k, p in v.items()}


def numbers_list(n: int) -> Check:
    """``n`` finite numbers within +-MAX_COORD, as a list of floats (a bezier curve)."""
    def nums(v, a: Arg) -> list[float]:
        arr = _numeric(v, 1)
        if arr is None or arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(np.abs(arr) > MAX_COORD):
            raise a.fail(f"be {n} finite numbers", v)
        return arr.tolist()
    return nums


TIME = number(0, MAX_TIME)
COORD = number()
#: a list position (Python's: negative counts from the end)
INDEX = integer(-(10 ** 9), 10 ** 9)
#: solver iterations per drag preview frame
ITERATIONS = integer(1, MAX_ITERATIONS)


def choice(options) -> Check:
    """One of ``options`` (strings)."""
    def one(v, a: Arg) -> str:
        if not isinstance(v, str) or v not in options:
            raise a.fail(f"be one of: {', '.join(options)}", v)
        return v
    return one


def pose_like(v, a: Arg):
    """A pose: None (the active one), a name, or a dict of pin targets (file form: plain
    data here; checked as a pose in a file is, with its JSON path, by the caller)."""
    if v is None or isinstance(v, str):
        return v
    if isinstance(v, Mapping):
        return plain(v, a)
    raise a.fail("be None, a pose name or a dict of pin targets", v)


def colour_or_image(v, a: Arg):
    """A background: an RGBA colour (4 whole numbers 0..255) or an (H, W, 4) uint8 image."""
    if isinstance(v, np.ndarray) and v.ndim == 3:
        if v.dtype != np.uint8 or v.shape[2] != 4 or v.shape[0] < 1 or v.shape[1] < 1:
            raise a.fail("be an RGBA colour or an (H, W, 4) uint8 image", v)
        return v
    arr = _numeric(v, 1)
    if arr is None or arr.shape != (4,) or np.any(arr != np.round(arr)) or arr.min() < 0 or arr.max() > 255:
        raise a.fail("be an RGBA colour (4 whole numbers 0..255) or an (H, W, 4) uint8 image", v)
    return tuple(int(x) for x in arr)
