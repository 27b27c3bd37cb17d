"""Dragging one pin: fast preview frames while the pointer moves, the exact frame on release.

While dragging, only the dragged pin's group is re-solved, warm-started from the
previous frame with a few ARAP iterations (other groups are taken from the exact solve
of the pose, cached). On release the pose is solved from scratch, so the final frame is
exactly ``scene.render(pose=<these targets>)`` whatever path the pointer took, and the
whole drag is one undo step.
"""
from __future__ import annotations

import numpy as np

from puppet.errors import SceneError


class Drag:
    """A drag of one pin of the active pose (made with ``scene.drag(name)``).

    A drag that starts at the reserved ``rest`` pose creates a new pose and makes it active.

    Parameters
    ----------
    scene : puppet.api.Scene
    pin : str
        An interior pin (or exterior point) name.
    iterations : int
        ARAP iterations per preview frame, warm-started from the previous one.
    size : (int, int), optional
        Size of the preview frames (default: the canvas).
    """

    def __init__(self, scene, pin: str, *, iterations: int = 4, size: tuple[int, int] | None = None):
        self.scene = scene
        self.pin = pin
        self.iterations = int(iterations)
        self.size = size
        scene._check_target_name(pin)
        self._ctx = scene.block(f"drag {pin}")
        self._ctx.__enter__()
        self.open = True
        try:
            if scene.active_pose == "rest":
                names = set(scene.pose_names())
                k = len(names)
                while f"pose{k}" in names:
                    k += 1
                scene.add_pose(f"pose{k}")
            self._built = scene.built
            self._state = scene.state()
            names = [p.name for p in scene.data.pins]
            self._index = names.index(pin) if pin in names else None
            self._group = self._built.group_of_pin(self._index) if self._index is not None else None
            self._U = None
            if self._group is not None:
                self._U = scene.rig.solve(self._built, self._group, self._state)[0]
            self._last = None
        except BaseException:
            self._close()
            raise

    def move(self, xy) -> np.ndarray:
        """Put the pin at canvas point ``xy``; returns a preview frame (H, W, 4) uint8."""
        return self.scene.draw_layers(self.move_layers(xy), size=self.size)

    def move_layers(self, xy) -> list:
        """Put the pin at canvas point ``xy``; returns the preview's posed layers
        (:class:`~puppet.scene.rig.LayerResult`), for a caller that draws them itself."""
        if not self.open:
            raise SceneError("this drag has been released")
        xy = np.asarray(xy, float).reshape(2)
        if not np.all(np.isfinite(xy)):
            raise SceneError(f"drag target must be finite, got {xy.tolist()}")
        self._last = xy
        scene, built = self.scene, self._built
        if self._group is None:  # an exterior point: solve exactly
            return scene.layers(self._pose_with(xy))
        self._state.to[self._index] = xy
        solved = scene.rig.preview(built, self._group, self._state, self._U, iterations=self.iterations)
        self._U = solved[0]
        return scene.rig.evaluate(built, self._state, solved={self._group: solved})

    def commit(self) -> None:
        """End the drag: record the pin's target in the active pose (one undo step)."""
        if not self.open:
            raise SceneError("this drag has been released")
        try:
            if self._last is not None:
                self.scene.set_target(self.pin, self._last)
        finally:
            self._close()

    def release(self) -> np.ndarray:
        """End the drag (:meth:`commit`) and return the exact frame."""
        self.commit()
        return self.scene.render(size=self.size)

    def cancel(self) -> None:
        """End the drag without changing the pose (a new pose made for it stays, undoable)."""
        if self.open:
            self._close()

    def _close(self) -> None:
        self.open = False
        self._ctx.__exit__(None, None, None)

    def _pose_with(self, xy) -> dict:
        """The active pose as JSON with this pin's target at ``xy`` (angle and depth kept)."""
        pose = self.scene.to_dict().get("poses", {}).get(self.scene.active_pose, {})
        t = pose.get(self.pin)
        pose[self.pin] = dict(t, to=xy.tolist()) if isinstance(t, dict) else xy.tolist()
        return pose
