"""Exterior control points of a scene: the user's exterior pins and the automatic ones
placed at contour curvature maxima (garment paper §3.3), each tied to its group mesh by
an edge-relative frame so that it rides along with the coarse deformation."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from puppet.deform.boundary import ExteriorFrame, exterior_frame
from puppet.errors import SceneError
from puppet.geom.contour import mask_regions, ring_area
from puppet.scene.format.load import CAGE_NAME, EXTERIOR_NAME


@dataclass
class GroupExterior:
    """Exterior points of one linked group."""

    names: list[str] = field(default_factory=list)
    layers: list[int] = field(default_factory=list)
    rest: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    frame: ExteriorFrame | None = None


def auto_points(mask: np.ndarray, offset, beta: float) -> np.ndarray:
    """Curvature-maxima points of every outer contour, largest component first, each in
    contour order from its topmost point. (j, 2) canvas coordinates."""
    from puppet.geom.curvature import curvature_maxima  # lazy: scenes with automatic exterior points only

    regions = sorted(mask_regions(mask, offset, grow=0), key=lambda r: -abs(ring_area(r.outer)))
    pts = []
    for reg in regions:
        if len(reg.outer) < 8:
            continue
        idx = curvature_maxima(reg.outer, beta=beta)
        pts.append(reg.outer[idx])
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def build_exterior(data, images, groups, cages=None) -> tuple[list[GroupExterior], dict[str, tuple[int, int]]]:
    """Exterior points per group, and name -> (group, index in the group). ``cages``: the
    rest cage of each caged layer (layer index -> (m, 2)); its vertices are its group's
    points ``LAYER:cageN`` (no exterior frame: the cage map moves that group)."""
    index = {L.name: L.index for L in data.layers}
    group_of = {k: gi for gi, g in enumerate(groups) for k in g.layers}
    per = [GroupExterior() for _ in groups]
    rest: list[list] = [[] for _ in groups]
    for k, C in (cages or {}).items():
        gi = group_of[k]
        per[gi].names += [f"{data.layers[k].name}:cage{j}" for j in range(len(C))]
        per[gi].layers += [k] * len(C)
        rest[gi] += list(C)
    for L in data.layers:
        if L.exterior is None:
            continue
        im = images[L.index]
        for j, xy in enumerate(auto_points(im.mask, im.offset, L.exterior.beta)):
            gi = group_of[L.index]
            per[gi].names.append(f"{L.name}:ext{j}")
            per[gi].layers.append(L.index)
            rest[gi].append(xy)
    for p in data.pins:
        if p.kind == "exterior":
            gi = group_of[index[p.layer]]
            per[gi].names.append(p.name)
            per[gi].layers.append(index[p.layer])
            rest[gi].append(p.at)
    where = {}
    for gi, (g, ge) in enumerate(zip(groups, per)):
        ge.rest = np.array(rest[gi], float).reshape(-1, 2)
        if len(ge.rest) and not any(data.layers[k].cage for k in g.layers):
            ge.frame = exterior_frame(g.mesh.V, ge.rest, g.mesh.F)
        for j, nm in enumerate(ge.names):
            where[nm] = (gi, j)
    for pname, pose in data.poses.items():
        for nm in pose:
            if EXTERIOR_NAME.match(nm) and nm not in where and nm not in {p.name for p in data.pins}:
                layer = EXTERIOR_NAME.match(nm).group("layer")
                count = sum(1 for n in where if n.startswith(layer + ":ext"))
                raise SceneError(f"layer {layer!r} has {count} automatic exterior points "
                                 f"({layer}:ext0 .. {layer}:ext{max(count - 1, 0)}), so {nm!r} does not exist",
                                 file=data.file, path=f"poses.{pname}.{nm}")
            mt = CAGE_NAME.match(nm)
            if mt and nm not in where and nm not in {p.name for p in data.pins}:
                layer, C = mt.group("layer"), cages[index[mt.group("layer")]]
                raise SceneError(f"layer {layer!r} has a cage of {len(C)} points ({layer}:cage0 .. "
                                 f"{layer}:cage{len(C) - 1}), so {nm!r} does not exist",
                                 file=data.file, path=f"poses.{pname}.{nm}")
    return per, where
