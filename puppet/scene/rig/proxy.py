"""A coarse proxy of a big group for drag previews: the same layer meshed with bigger
triangles (its pins kept as vertices), solved and drawn instead of the fine mesh while
the pointer moves; the release solves the fine mesh exactly.

A 4000x4000 garment photo meshes into ~18k vertices and ~34k triangles: a warm-started
ARAP step of the fine mesh costs a few ms, but drawing 34k small triangles every frame on
a software rasteriser costs more. The proxy (:data:`PROXY_VERTICES` vertices) is solved
in a fraction of that and drawn with a sixth of the triangles; the texture follows it, as
the texture coordinates come from the rest positions.

Only one-layer groups without exterior points get a proxy (the big picture case); a pose
with pin angles is previewed on the fine mesh (:func:`~puppet.scene.rig.solve.preview_group`
solves those exactly).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.arap import ArapData, arap_precompute, arap_solve
from puppet.deform.depth import depth_field
from puppet.errors import SceneError
from puppet.geom.triangulate import edge_length_for_area, triangulate_regions
from puppet.scene.rig import build
from puppet.scene.rig.cache import fingerprint
from puppet.scene.rig.core import LayerResult

#: Groups with more vertices than this are previewed on a proxy.
PROXY_MIN = 12000
#: About how many vertices a proxy has.
PROXY_VERTICES = 3000


@dataclass
class Proxy:
    """The coarse mesh of one group's only layer and its ARAP precomputation."""

    layer: int  # scene layer index
    mesh: object  # geom.triangulate.Mesh: V (n, 2), F (m, 3)
    pins: dict[str, int]  # interior pin name -> proxy vertex
    arap: ArapData


def proxy_for(rig, built, gi: int) -> Proxy | None:
    """The proxy of group ``gi`` (built once per group version, kept in the rig's
    cache), or None when the group is small or not a plain one-layer group."""
    g, data = built.groups[gi], built.data
    if (len(g.mesh.V) <= PROXY_MIN or len(g.layers) != 1 or built.exterior[gi].frame is not None
            or data.deformer.method != "arap" or not len(g.pins) or not _plain_rigid(data, g.layers[0])):
        return None
    return rig.memo.get("precompute", fingerprint("proxy", built.pre_keys[gi], PROXY_VERTICES),
                        lambda: _build(built, gi))


def _plain_rigid(data, k: int) -> bool:
    """Layer ``k`` is deformed by plain ARAP cells (rigid mode, no painted stiffness, no
    starch pin): what the proxy solves. Other cells are previewed on the fine mesh, so
    that a preview never shows another mode than its release."""
    L = data.layers[k]
    return ((L.mode or data.deformer.mode) == "rigid" and L.stiffness is None
            and not any(p.kind == "starch" and p.layer == L.name for p in data.pins))


def _build(built, gi: int) -> Proxy | None:
    """The proxy, or None when the coarse mesh cannot be made (the fine mesh is previewed)."""
    g, data = built.groups[gi], built.data
    k = g.layers[0]
    im = built.images[k]
    L = data.layers[k]
    area = (L.mesh.max_area or build.default_max_area(im.mask)) * len(g.mesh.V) / PROXY_VERTICES
    pts = np.array([p.at for _, p in build.layer_pins(data, k)]).reshape(-1, 2)
    try:  # the outline simplified to an eighth of the proxy's edge length: a third fewer triangles
        mesh = triangulate_regions(built.regions[k], max_area=area, min_angle=L.mesh.min_angle,
                                   simplify=max(L.mesh.simplify, edge_length_for_area(area) / 8), points=pts)
        pins = build.pin_vertices(data, k, mesh)
        b = np.array([pins[data.pins[i].name] for i in g.pins], np.int64)
        d = data.deformer
        return Proxy(layer=k, mesh=mesh, pins=pins, arap=arap_precompute(mesh.V, mesh.F, b, weights=d.weights,
                                                                         alpha=d.alpha))
    except (SceneError, ValueError):  # (MeshTooLarge is a ValueError)
        return None


def proxy_solve(proxy: Proxy, bc: np.ndarray, U0: np.ndarray | None, iterations: int) -> np.ndarray:
    """Proxy vertices (n, 2) with the pins at ``bc`` (k, 2): warm-started from ``U0``, or
    (first frame) solved from the MLS guess with twenty iterations."""
    if U0 is None:
        return arap_solve(proxy.arap, bc, iterations=20)
    return arap_solve(proxy.arap, bc, iterations=iterations, U0=U0)


def proxy_layer(proxy: Proxy, built, gi: int, U: np.ndarray, pin_depth: np.ndarray):
    """The group's layer drawn as the deformed proxy: a
    :class:`~puppet.scene.rig.core.LayerResult` (rest, deformed and triangles of the proxy;
    ``pin_depth``: (k,) the scene pins' depths)."""
    g, k = built.groups[gi], proxy.layer
    r = built.rank[k]
    depth = depth_field(proxy.arap.D, pin_depth[g.pins], alpha=built.data.deformer.alpha)
    return LayerResult(name=built.data.layers[k].name, group=gi, order=r, rest=proxy.mesh.V, deformed=U,
                       triangles=proxy.mesh.F, depth=r + depth, pins=dict(proxy.pins), exterior={},
                       key=built.image_keys[k])
