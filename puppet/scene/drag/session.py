"""One drag session for every drag: a pin or several pins of the active pose, pins keyed
at a time on the timeline, and record mode, with fast previews and an exact release.

While the pointer moves, only the groups holding a moved pin are re-solved (in record
mode, every group with pins, as the others move with time too): a big group on its
reduced model (:mod:`puppet.scene.rig.reduced`: a coarse copy solved as an exact pose
is, drawn in its place), a small one warm-started from its previous frame
(:func:`~puppet.scene.rig.solve.preview_group`); the other groups come from the exact
solve of the pose the drag started from (cached). The release records the targets in
one undo step and returns the exact layers, solved from scratch: exactly what
``render(pose=...)`` (a pose drag) or ``render(time=...)`` (a key drag, a recording)
draws, whatever path the pointer took.

:func:`pose_with` is the one "this pose with those pins moved" of the code base.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from puppet.errors import SceneError
from puppet.scene.drag.process import DragProcess, unpack
from puppet.scene.format import args as ck
from puppet.scene.rig.reduced import detailed, reduced_for, reduced_layers, reduced_solve, residual
from puppet.scene.rig.solve import PinState, preview_group


def pose_with(pose: dict, targets: Mapping) -> dict:
    """A copy of the file-form pins table ``pose`` with ``targets`` ({name: (x, y)}) as
    the positions of those pins (their angle and depth, when given, kept)."""
    out = dict(pose)
    for name, xy in targets.items():
        to = [float(xy[0]), float(xy[1])]
        cur = out.get(name)
        out[name] = dict(cur, to=to) if isinstance(cur, dict) else to
    return out


def base_pose(doc, time: float | None = None) -> dict:
    """The file-form pins table a drag starts from: the animation's pose at ``time``
    (``pose_at``) when given and the scene has keys, else the active pose (``{}`` at rest)."""
    if time is not None and doc.data.animation is not None:
        return dict(doc.pose_at(time))
    if doc.active_pose == "rest":
        return {}
    return dict(doc.to_dict().get("poses", {}).get(doc.active_pose, {}))


def warm(doc) -> int:
    """Build ahead what the first preview frame of a drag in ``doc`` needs that a render
    does not: the reduced models of its big groups (kept in the rig's memo, so the drag
    finds them). Returns how many groups have one. An app runs it while it is idle, so
    that the first pointer move of a drag on big art does not wait for them."""
    built = doc.built
    return sum(reduced_for(doc.rig, built, gi) is not None for gi in range(len(built.groups)))


def _file_form(pins: Mapping) -> dict:
    """{name: [x, y]} of floats."""
    return {n: [float(xy[0]), float(xy[1])] for n, xy in pins.items()}


def drag_solver(v, a: ck.Arg):
    """A drag's ``solver``: a :class:`~puppet.scene.drag.process.DragProcess`."""
    if not isinstance(v, DragProcess):
        raise a.fail("be a puppet.scene.drag.process.DragProcess or None", v)
    return v


def _document(v, a: ck.Arg):
    """A drag's document: anything with a scene's ``data``, ``built`` and ``events``."""
    if not all(hasattr(v, k) for k in ("data", "built", "events", "file")):
        raise a.fail("be a scene (puppet.api.Scene or a Document)", v)
    return v


def drag_targets(v, a: ck.Arg):
    """Where to put the dragged pins: ``(x, y)`` or ``{name: (x, y)}``."""
    if isinstance(v, Mapping):
        if not all(isinstance(k, str) for k in v):
            raise a.fail("be (x, y) or a dict of pin names to (x, y)", v)
        return {k: ck.point(xy, a) for k, xy in v.items()}
    return ck.point(v, a)


def _record(doc, t0: float, keys: dict) -> None:
    """Store recorded ``keys`` ({time: {name: [x, y]}}) from ``t0`` on, one undo step
    (pose keys in the span keep their pose: ``Document.record_motion``)."""
    doc.record_motion(keys, start=min(t0, min(keys)), end=max(keys))


class DragSession:
    """A drag of pins ``names`` (made by ``doc.drag(names, time=None, record=False)``).

    Parameters
    ----------
    doc : puppet.scene.document.core.Document
    names : str or list of str
        Interior pins and exterior points to drag.
    time : float, optional
        None: drag in the active pose (a drag started at ``rest`` makes a new active pose
        on commit). A time: key the pins there (a key drag), or with ``record``, the time
        the recording starts.
    record : bool
        Record mode: :meth:`commit` takes the recorded keys.
    iterations : int
        ARAP iterations per preview frame, warm-started from the previous frame (groups
        without a reduced model; a reduced model is solved as an exact pose is).
    """

    @ck.checked("DragSession", doc=_document, names=ck.texts, time=ck.optional(ck.TIME), record=ck.flag,
                iterations=ck.ITERATIONS, solver=ck.optional(drag_solver))
    def __init__(self, doc, names, time: float | None = None, *, record: bool = False, iterations: int = 4,
                 solver=None):
        names = [names] if isinstance(names, str) else list(names)
        if not names:
            raise SceneError("a drag needs at least one pin", file=doc.file)
        for n in names:
            doc._check_target_name(n)
        if len(set(names)) != len(names):
            raise SceneError(f"a pin is named twice in the drag: {names}", file=doc.file)
        if record and time is None:
            raise SceneError("record mode needs the time the recording starts", file=doc.file)
        if time is not None and not (np.isfinite(time) and time >= 0):
            raise SceneError(f"time must be a number >= 0, got {time}", file=doc.file)
        self.doc, self.names, self.record = doc, names, bool(record)
        self.time = None if time is None else float(time)
        self.iterations = int(iterations)
        self.open = True
        self._last: dict[str, np.ndarray] | None = None
        self._solver, self._serial = solver, None
        self._rebuild()
        doc.events.connect(self._changed)

    def _rebuild(self) -> None:
        """Take the scene as it is now: its built parts, the start state, where each
        dragged pin is in it, the groups to re-solve; no previous frame to start from."""
        doc = self.doc
        for n in self.names:
            doc._check_target_name(n)
        self._built = doc.built
        self._state = self._start_state(self.time)
        pins = {p.name: i for i, p in enumerate(self._built.data.pins) if p.kind == "interior"}
        ext = [n for ge in self._built.exterior for n in ge.names]
        self._where = {n: ("pin", pins[n]) if n in pins else ("ext", ext.index(n)) for n in self.names}
        self._moved = self._groups_of(self.names)
        self._U: dict = {}  # group -> its previous preview frame (groups without a reduced model)
        self._detail: dict = {}  # group -> its reduced model's detail residual at the drag's start
        self._stale = False
        if self._serial is None and self._solver is not None and self._solver.alive:
            self._serial = self._solver.open(doc, self.names, self.time, self.record, self.iterations)

    def _changed(self, event) -> None:
        """A document event during the drag: anything that changes a solve (an undo, a
        pin or mesh edit, another pose shown) makes the next frame start afresh."""
        if event.level != "none":
            self._stale = True
            if self._serial is not None and self._solver.alive:  # the solver process starts on it now
                self._serial = self._solver.open(self.doc, self.names, self.time, self.record, self.iterations)

    # -- previews -----------------------------------------------------------------------
    @ck.checked(targets=drag_targets, time=ck.optional(ck.TIME))
    def move_layers(self, targets, time: float | None = None) -> list:
        """Put the pins at ``targets`` ({name: (x, y)}, or one (x, y) for a one-pin drag);
        returns the preview's posed layers (:class:`~puppet.scene.rig.core.LayerResult`).

        ``time`` (record mode only): the playhead now; the other pins are where the
        animation has them then."""
        if not self.open:
            raise SceneError("this drag has been released", file=self.doc.file)
        if self._stale:
            self._rebuild()
        targets = self._targets(targets)
        if time is not None:
            if not self.record:
                raise SceneError("only a recording moves in time (give time= to drag() instead)", file=self.doc.file)
            self._state = self._start_state(float(time))
        state = self._state
        for n, xy in targets.items():
            kind, i = self._where[n]
            (state.to if kind == "pin" else state.ext_to)[i] = xy
        self._last = targets
        if self._serial is not None and self._solver.wait_ready(self._serial, 0):
            packed = self._solver.move(self._serial, targets, time)
            if packed is not None:  # solved in the solver process
                return unpack(self._evaluate(state, {}), packed)
        return self._preview(state)

    def _preview(self, state) -> list:
        rig, built = self.doc.rig, self._built
        solved, reduced = {}, {}
        for gi in self._moved:
            g = built.groups[gi]
            ext = built.ext_slices()[gi]
            if not len(g.pins) or not np.isnan(state.ext_to[ext, 0]).all() or (built.cages and built.cages[gi]):
                solved[gi] = rig.solve(built, gi, state)  # no pins, an exterior point pulls it, a cage: exact
                continue
            red = reduced_for(rig, built, gi)
            if red is not None:  # a big group: its reduced model is solved and drawn
                reduced[gi] = (red, *self._reduced(gi, red, state))
                continue
            U0 = self._U.get(gi)
            if U0 is None:  # the first frame starts from the exact solve it moves away from
                U0 = rig.solve(built, gi, self._start)[0]
            solved[gi] = preview_group(built.pre[gi], g, built.data.deformer, built.exterior[gi],
                                       built.group_pose(gi, state), U0, iterations=self.iterations)
            self._U[gi] = solved[gi][0]
        layers = self._evaluate(state, solved)
        for gi, (red, U, depth) in reduced.items():
            for k, layer in reduced_layers(red, built, gi, U, depth).items():
                layers[k] = layer
        return layers

    def _reduced(self, gi: int, red, state) -> tuple[np.ndarray, np.ndarray]:
        """Coarse vertices and depth of group ``gi``'s reduced model in ``state``, with the
        detail residual of the exact pose the drag started from."""
        built, d = self._built, self._built.data.deformer
        if gi not in self._detail:
            Uc0, _ = reduced_solve(red, d, built.group_pose(gi, self._start))
            self._detail[gi] = residual(red, Uc0, self.doc.rig.solve(built, gi, self._start)[0])
        Uc, depth = reduced_solve(red, d, built.group_pose(gi, state))
        return detailed(red, Uc, self._detail[gi]), depth

    def _evaluate(self, state, solved: dict) -> list:
        """The layers of ``state`` with the groups of ``solved`` as given, the other moved
        groups left at rest (their layers are replaced by the caller), the rest exact."""
        built = self._built
        stand_in = {gi: (built.groups[gi].mesh.V, np.zeros(len(built.groups[gi].mesh.V)),
                         np.zeros((len(built.exterior[gi].names), 2))) for gi in self._moved}
        return self.doc.rig.evaluate(built, state, solved={**stand_in, **solved})

    # -- the end --------------------------------------------------------------------------
    @ck.checked(keys=ck.optional(ck.timed_tables))
    def commit(self, keys: Mapping | None = None) -> None:
        """End the drag and record it in one undo step: the last targets in the active
        pose (a pose drag), in the key at ``time`` (a key drag), or, in record mode,
        ``keys`` = {time: {name: (x, y)}} replacing the pins' keys over the recorded span.
        A drag that never moved changes nothing."""
        if not self.open:
            raise SceneError("this drag has been released", file=self.doc.file)
        self._close()
        doc = self.doc
        if self.record:
            if keys:
                _record(doc, self.time, {float(t): _file_form(p) for t, p in keys.items()})
            return
        if self._last is None:
            return
        if self.time is not None:
            with doc.block(f"key {', '.join(self.names)} at {self.time:g} s"):
                doc.key_pins(self.time, _file_form(self._last))
            return
        pose = doc.active_pose  # "rest": set_target makes a new pose
        with doc.block(f"move {', '.join(self.names)} in " + ("a new pose" if pose == "rest" else pose)):
            for n, xy in self._last.items():
                doc.set_target(n, xy)

    @ck.checked(keys=ck.optional(ck.timed_tables))
    def release_layers(self, keys: Mapping | None = None) -> list:
        """:meth:`commit`, then the exact layers: ``doc.layers()`` for a pose drag,
        ``doc.layers(time=time)`` for a key drag or a recording. A scene that opts into
        accelerated solves (``deformer.accelerate``) starts them from the last previews."""
        starts = {gi: U for gi, U in self._U.items() if isinstance(gi, int)} \
            if self.doc.data.deformer.accelerate != "none" else {}
        built = self._built
        self.commit(keys)
        with self.doc.rig.warm_started(built, starts):
            if self.time is not None and self.doc.data.animation is not None:
                return self.doc.layers(time=self.time)
            return self.doc.layers()

    @ck.checked()
    def cancel(self) -> None:
        """End the drag without changing anything."""
        if self.open:
            self._close()

    def _close(self) -> None:
        self.open = False
        self.doc.events.disconnect(self._changed)

    # -- helpers ----------------------------------------------------------------------------
    def _start_state(self, time: float | None):
        """A copy of the pin state at ``time`` (the animation's) or of the active pose; the
        state itself is kept as the one each group's first preview frame starts from."""
        doc = self.doc
        s = doc.state(time=time) if time is not None and doc.data.animation is not None else doc.state()
        self._start = s
        return PinState(to=s.to.copy(), angle=s.angle.copy(), depth=s.depth.copy(), ext_to=s.ext_to.copy())

    def _groups_of(self, names) -> list[int]:
        """Groups re-solved per frame: those holding a dragged pin (every group with pins
        in record mode)."""
        built = self._built
        if self.record:
            return [gi for gi, g in enumerate(built.groups) if len(g.pins)]
        out = set()
        for n in names:
            kind, i = self._where[n]
            if kind == "pin":
                out.add(built.group_of_pin(i))
            else:
                out.update(gi for gi, s in enumerate(built.ext_slices()) if s.start <= i < s.stop)
        return sorted(out)

    def _targets(self, targets) -> dict[str, np.ndarray]:
        if not isinstance(targets, Mapping):
            if len(self.names) != 1:
                raise SceneError(f"this drag moves {len(self.names)} pins: give {{name: (x, y)}}", file=self.doc.file)
            targets = {self.names[0]: targets}
        out = {}
        for n, xy in targets.items():
            if n not in self._where:
                raise SceneError(f"{n!r} is not one of the dragged pins ({', '.join(self.names)})", file=self.doc.file)
            xy = np.asarray(xy, float).reshape(-1)
            if xy.shape != (2,) or not np.all(np.isfinite(xy)):
                raise SceneError(f"drag target must be two finite numbers, got {xy.tolist()}")
            out[n] = xy
        if self._last is not None:  # pins not given this time stay where they were
            out = {**self._last, **out}
        return out
