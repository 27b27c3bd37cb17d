"""Animation keys of a scene as methods: add, move, copy, remove keys, change their ease,
the frame rate, the in-between and depth modes; and reading the keys back.

Each edit goes through ``Document._edit`` (validated like a loaded file, one undo step,
one ``"animation"`` event, only on a real change). Keys are written in the file form of
the scene format: ``{"time": s, "pose": NAME}`` (with ``"overrides": {PIN: target |
null}`` when some pins differ from the pose or are left out) or ``{"time": s, "pins":
{PIN: [x, y] | {"to": [x, y], "angle": deg, "depth": d}}}``, with ``"ease"`` when not
``linear`` and ``"curve"`` for ``bezier``. :meth:`KeyEdits.record_motion` writes a
recorded motion over a span of keys and keeps their poses.
"""
from __future__ import annotations

import numpy as np

from puppet.scene.document.history import Event
from puppet.scene.document.recording import recorded, write_motion
from puppet.scene.format import args as ck
from puppet.scene.format.animation import SAME_TIME, pins_json
from puppet.scene.format.model import DEPTH_MODES, EASES, INBETWEENS
from puppet.scene.time.evaluate import exterior_names
from puppet.scene.time.tracks import mentions


def _ease_fields(key: dict, ease: str, curve) -> None:
    key.pop("ease", None)
    key.pop("curve", None)
    if ease != "linear":
        key["ease"] = ease
    if curve is not None:
        key["curve"] = [float(c) for c in curve]


class KeyEdits:
    """Animation-key methods of :class:`puppet.scene.document.core.Document` (a mixin)."""

    # helpers ------------------------------------------------------------------------
    def _keys_of(self, doc: dict) -> list[dict]:
        anim = doc.get("animation")
        if anim is None:
            raise self._fail("the scene has no animation yet (add a key first)")
        return anim["keys"]

    def _key_at(self, doc: dict, time: float) -> dict:
        for k in self._keys_of(doc):
            if abs(k["time"] - float(time)) <= SAME_TIME:
                return k
        raise self._fail(f"no animation key at {float(time):g} s")

    @staticmethod
    def _put_key(doc: dict, key: dict) -> None:
        """Insert ``key``, replacing any key at its time, keeping the keys sorted."""
        anim = doc.setdefault("animation", {"fps": 24, "keys": []})
        keys = [k for k in anim["keys"] if abs(k["time"] - key["time"]) > SAME_TIME]
        keys.append(key)
        anim["keys"] = sorted(keys, key=lambda k: k["time"])

    def _check_ease(self, ease: str, curve) -> None:
        if ease not in EASES:
            raise self._fail(f"{ease!r} is not an ease (eases: {', '.join(EASES)})")
        if (ease == "bezier") != (curve is not None):
            raise self._fail("a curve [cx1, cy1, cx2, cy2] goes with the 'bezier' ease, and only with it")

    # edits --------------------------------------------------------------------------
    @ck.checked(time=ck.TIME, pose=ck.optional(ck.text), pins=ck.optional(ck.pins_table()), ease=ck.text,
                curve=ck.optional(ck.numbers_list(4)), overrides=ck.optional(ck.pins_table(nulls=True)))
    def set_key(self, time: float, pose: str | None = None, *, pins: dict | None = None, ease: str = "linear",
                curve=None, overrides: dict | None = None) -> bool:
        """A key at ``time`` seconds showing pose ``pose`` (a name, ``"rest"`` included) or
        the pin targets ``pins`` (file form; only the pins named), replacing a key at that
        time. ``ease`` shapes the segment ending at this key; ``curve`` = (cx1, cy1, cx2,
        cy2) for ``"bezier"``. With a pose, ``overrides`` (file form; None for a pin the
        key leaves out) replace the pose's targets of the pins they name."""
        if (pose is None) == (pins is None):
            raise self._fail("a key shows a pose name or pin targets (give one of pose= and pins=)")
        if overrides is not None and pose is None:
            raise self._fail("overrides go with a pose key (pose=); a pins key names its pins itself")
        self._check_ease(ease, curve)
        key: dict = {"time": float(time)}
        if pose is not None:
            key["pose"] = pose
            if overrides:
                key["overrides"] = pins_json(overrides)
        else:
            key["pins"] = pins_json(pins)
        _ease_fields(key, ease, curve)

        def m(doc):
            self._put_key(doc, key)
        return self._edit(Event("animation", pose or "", "none", f"key at {float(time):g} s"), m)

    @ck.checked(animation=ck.optional(ck.plain), label=ck.text)
    def set_animation(self, animation, label: str = "set animation") -> bool:
        """Replace the scene's whole ``animation`` (the scene format's value; None removes
        it), one undo step labelled ``label``: a retargeted motion written at once."""
        def m(doc):
            if animation is None:
                doc.pop("animation", None)
            else:
                doc["animation"] = animation
        return self._edit(Event("animation", "", "none", label), m)

    @ck.checked(chains=ck.plain)
    def set_physics(self, chains) -> bool:
        """The scene's secondary motion, one undo step: ``chains`` as the scene format's
        ``physics.chains`` (``[{"pins": [...], "frequency": 2.0, "damping": 0.3,
        "gravity": 0.0}, ...]``); an empty list removes ``physics``."""
        def m(doc):
            if chains:
                doc["physics"] = dict(doc.get("physics") or {}, chains=chains)
            else:
                doc.pop("physics", None)
        return self._edit(Event("animation", "", "none", "set physics chains" if chains else "remove physics"), m)

    @ck.checked(keys=ck.timed_tables, start=ck.optional(ck.TIME), end=ck.optional(ck.TIME))
    def record_motion(self, keys: dict, *, start: float | None = None, end: float | None = None) -> bool:
        """Write recorded keys of some pins over the span ``start``..``end`` (default: the
        first to the last recorded time), keeping every other pin's keys and the keys' poses;
        one undo step. What the app's record mode writes.

        ``keys`` is ``{time: {pin: [x, y] | {"to", "angle", "depth"}}}`` (what
        :meth:`puppet.app.model.record.Recording.keys` returns). Inside the span the recorded pins
        follow only the recorded keys: a pose key there keeps its pose and gets an override
        leaving those pins out (or, at a recorded time, giving their recorded targets); a
        pins key there loses them (and goes when it names nothing else). At a recorded
        time with no key, a pins key is added. A recorded ``[x, y]`` keeps the angle and
        depth the pin has at that time in the animation (only its position is recorded).
        """
        if not keys:
            raise self._fail("nothing recorded (no keys)")
        times = sorted(float(t) for t in keys)
        t0 = times[0] if start is None else float(start)
        t1 = times[-1] if end is None else float(end)
        if not (np.isfinite(t0) and np.isfinite(t1) and 0 <= t0 <= times[0] and times[-1] <= t1):
            raise self._fail(f"the span {t0:g}..{t1:g} s must hold every recorded time ({times[0]:g}..{times[-1]:g} s)")
        table = recorded(self, keys)

        def m(doc):
            write_motion(doc, table, t0 - SAME_TIME, t1 + SAME_TIME)
        names = sorted({n for pins in table.values() for n in pins})
        return self._edit(Event("animation", "", "none", f"record {', '.join(names)} {t0:g}-{t1:g} s"), m)

    @ck.checked(time=ck.TIME, pins=ck.pins_table())
    def key_pins(self, time: float, pins: dict) -> bool:
        """Key ``pins`` (``{pin: [x, y] | {"to", "angle", "depth"}}``) at ``time``, keeping
        what a key there holds: a pose key keeps its pose and gets them as ``overrides``, a
        pins key gets them added, and with no key there a pins key is made. A ``[x, y]``
        keeps the angle and depth the pin has at that time (only its position changes)."""
        if not pins:
            raise self._fail("no pins to key")
        table = recorded(self, {float(time): pins})

        def m(doc):
            write_motion(doc, table, 1.0, 0.0)  # an empty span: no key loses a pin
        return self._edit(Event("animation", "", "none", f"key {', '.join(pins)} at {float(time):g} s"), m)

    @ck.checked(time=ck.TIME)
    def remove_key(self, time: float) -> bool:
        """Remove the key at ``time`` (the animation goes with its last key)."""
        def m(doc):
            gone = self._key_at(doc, time)
            keys = [k for k in doc["animation"]["keys"] if k is not gone]
            if keys:
                doc["animation"]["keys"] = keys
            else:
                del doc["animation"]
        return self._edit(Event("animation", "", "none", f"remove key at {float(time):g} s"), m)

    @ck.checked(time=ck.TIME, new_time=ck.TIME)
    def move_key(self, time: float, new_time: float) -> bool:
        """Move the key at ``time`` to ``new_time`` (replacing a key there)."""
        def m(doc):
            key = self._key_at(doc, time)
            doc["animation"]["keys"].remove(key)
            self._put_key(doc, dict(key, time=float(new_time)))
        return self._edit(Event("animation", "", "none", f"move key {float(time):g} s -> {float(new_time):g} s"), m)

    @ck.checked(time=ck.TIME, new_time=ck.TIME)
    def copy_key(self, time: float, new_time: float) -> bool:
        """Copy the key at ``time`` to ``new_time`` (replacing a key there)."""
        def m(doc):
            self._put_key(doc, dict(self._key_at(doc, time), time=float(new_time)))
        return self._edit(Event("animation", "", "none", f"copy key {float(time):g} s -> {float(new_time):g} s"), m)

    @ck.checked(time=ck.TIME, ease=ck.text, curve=ck.optional(ck.numbers_list(4)))
    def set_key_ease(self, time: float, ease: str, curve=None) -> bool:
        """The ease of the segment ending at the key at ``time`` (``curve`` for ``"bezier"``)."""
        self._check_ease(ease, curve)

        def m(doc):
            _ease_fields(self._key_at(doc, time), ease, curve)
        return self._edit(Event("animation", "", "none", f"ease of key at {float(time):g} s"), m)

    def _set_anim(self, field: str, value, label: str) -> bool:
        """Set an animation-wide field; the value it has now (its default included) is no change."""
        def m(doc):
            self._keys_of(doc)
            if getattr(self.data.animation, field) != value:
                doc["animation"][field] = value
        return self._edit(Event("animation", "", "none", label), m)

    @ck.checked(fps=ck.number(0, 240, lo_open=True))
    def set_fps(self, fps: float) -> bool:
        """Frames per second of the animation (0 < fps <= 240)."""
        return self._set_anim("fps", fps, "change fps")

    @ck.checked(kind=ck.text)
    def set_inbetween(self, kind: str) -> bool:
        """``"rigid"`` (shape-preserving in-betweens) or ``"linear"`` (pins on straight lines)."""
        if kind not in INBETWEENS:
            raise self._fail(f"{kind!r} is not an in-between (one of: {', '.join(INBETWEENS)})")
        return self._set_anim("inbetween", kind, f"in-betweens {kind}")

    @ck.checked(mode=ck.text)
    def set_depth_mode(self, mode: str) -> bool:
        """Pin depth ``"step"``s at keys or ``"interpolate"``s between them."""
        if mode not in DEPTH_MODES:
            raise self._fail(f"{mode!r} is not a depth mode (one of: {', '.join(DEPTH_MODES)})")
        return self._set_anim("depth", mode, f"depth {mode}")

    # reading ------------------------------------------------------------------------
    @ck.checked()
    def keys(self) -> list[dict]:
        """The animation's keys in file form, sorted by time (a copy; [] without animation)."""
        anim = self.to_dict().get("animation")
        return anim["keys"] if anim else []

    @ck.checked(pin=ck.optional(ck.text))
    def key_times(self, pin: str | None = None) -> list[float]:
        """Times of the keys that mention ``pin`` (a pose key mentions every pin; a pins
        key those it names); of every key when None."""
        if self.data.animation is None:
            return []
        try:
            hit = mentions(self.tracks(), pin, self.data, self.built.exterior)
        except KeyError:
            raise self._fail(f"no pin or exterior point named {pin!r}") from None
        return [float(t) for t, h in zip(self.tracks().times, hit) if h]

    @ck.checked()
    def duration(self) -> float:
        """Time of the last key in seconds (0 without animation)."""
        anim = self.data.animation
        return float(anim.keys[-1].time) if anim else 0.0

    @ck.checked(time=ck.TIME)
    def pose_at(self, time: float) -> dict:
        """The pose shown at ``time`` as a file-form pins table (what "Key" stores): every
        interior pin where the frame shows it (``[x, y]``, or ``{"to", "angle", "depth"}``
        when it is turned or its depth differs from the pin's own), and each exterior point
        a key gives a target."""
        state = self.state(time=time)
        where = {}
        if self.data.animation.inbetween == "rigid":  # the pins where the in-between puts them
            for r in self.layers(time=time):
                where.update({p: r.deformed[v] for p, v in r.pins.items()})
        out: dict = {}
        for i, p in enumerate(self.data.pins):
            if p.kind != "interior":
                continue
            to = [float(x) for x in where.get(p.name, state.to[i])]
            angle, depth = float(state.angle[i]), float(state.depth[i])
            if angle == 0.0 and depth == p.depth:
                out[p.name] = to
            else:
                out[p.name] = {"to": to, "angle": angle, "depth": depth}
        for j, name in enumerate(exterior_names(self.built.exterior)):
            if not np.isnan(state.ext_to[j, 0]):
                out[name] = [float(x) for x in state.ext_to[j]]
        return out
