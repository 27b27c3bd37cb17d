"""Pin states: a named pose, an ad-hoc pose or a time on the animation -> where every pin is."""
from __future__ import annotations

import numpy as np

from puppet.errors import SceneError
from puppet.scene.format.model import SceneData, Target
from puppet.scene.rig.exterior import GroupExterior
from puppet.scene.rig.solve import PinState

__all__ = ["PinState", "rest_state", "pose_state", "blend"]


def exterior_names(exterior: list[GroupExterior]) -> list[str]:
    return [n for ge in exterior for n in ge.names]


def rest_state(data: SceneData, exterior: list[GroupExterior]) -> PinState:
    j = len(exterior_names(exterior))
    return PinState(to=np.array([p.at for p in data.pins], float).reshape(-1, 2),
                    angle=np.zeros(len(data.pins)), depth=np.array([p.depth for p in data.pins], float),
                    ext_to=np.full((j, 2), np.nan))


def pose_state(data: SceneData, exterior: list[GroupExterior], pose: dict[str, Target]) -> PinState:
    """Pin targets of a named pose's table (pins not named stay at rest; exterior points
    not named ride along with the mesh)."""
    s = rest_state(data, exterior)
    index = {p.name: i for i, p in enumerate(data.pins) if p.kind == "interior"}
    ext = {n: i for i, n in enumerate(exterior_names(exterior))}
    for name, t in pose.items():
        if name in ext:
            if t.to is not None:
                s.ext_to[ext[name]] = t.to
            continue
        if name not in index:
            raise SceneError(f"the pose names {name!r}, which is not a pin or exterior point of the scene",
                             file=data.file, path=name)
        i = index[name]
        if t.to is not None:
            s.to[i] = t.to
        s.angle[i] = t.angle
        if t.depth is not None:
            s.depth[i] = t.depth
    return s


def blend(a: PinState, b: PinState, t: float, ext_rest: np.ndarray) -> PinState:
    """Linear blend of two pin states. An exterior point moved in only one of them blends
    from its rest position on the other side (``ext_rest``, (j, 2))."""
    ea, eb = a.ext_to, b.ext_to
    both_free = np.isnan(ea[:, 0]) & np.isnan(eb[:, 0])
    ea = np.where(np.isnan(ea), ext_rest, ea)
    eb = np.where(np.isnan(eb), ext_rest, eb)
    ext = (1 - t) * ea + t * eb
    ext[both_free] = np.nan
    return PinState(to=(1 - t) * a.to + t * b.to, angle=(1 - t) * a.angle + t * b.angle,
                    depth=(1 - t) * a.depth + t * b.depth, ext_to=ext)
