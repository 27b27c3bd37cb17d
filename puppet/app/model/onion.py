"""The onion skin: which times are ghosted around the playhead (:func:`ghost_times`; the
scene session solves them through its frame cache, :mod:`puppet.app.model.snapshot`, and
:mod:`puppet.app.gl.ghosts` draws them), and its default settings.
"""
from __future__ import annotations

#: default onion skin settings (the timeline panel edits a copy)
DEFAULTS = {"mode": "keys", "count": 1, "opacity": 0.4, "before": (0.9, 0.15, 0.1), "after": (0.1, 0.75, 0.2),
            "fps": 24.0}


def key_times(anim: dict | None) -> list[float]:
    """Sorted distinct key times of an animation in file form (every track)."""
    if not anim:
        return []
    return sorted({float(k["time"]) for k in anim.get("keys", [])})


def ghost_times(anim: dict | None, t: float, *, mode: str = "keys", count: int = 1, fps: float = 24.0,
                **_) -> list[tuple[str, float, float]]:
    """The onion skin around time ``t``: ``(side, weight, time)`` for each ghost.

    ``mode="keys"``: the ``count`` keys before and after ``t`` (a key at ``t`` itself is the
    current frame); ``mode="frames"``: ``t ± k / fps`` for k = 1..count, inside the
    animation. ``weight`` is 1 for the nearest ghost and falls off linearly.
    """
    times = key_times(anim)
    if not times or count < 1:
        return []
    eps = 1e-6
    if mode == "frames":
        before = [t - k / fps for k in range(1, count + 1) if t - k / fps >= times[0] - eps]
        after = [t + k / fps for k in range(1, count + 1) if t + k / fps <= times[-1] + eps]
    else:
        before = [k for k in reversed(times) if k < t - eps][:count]
        after = [k for k in times if k > t + eps][:count]
    out = []
    for side, ts in (("before", before), ("after", after)):
        for k, gt in enumerate(ts):
            out.append((side, 1.0 - k / max(count, 1), float(gt)))
    return out
