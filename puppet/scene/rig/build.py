"""From a validated scene to the things every pose needs: layer textures, masks,
meshes, linked groups. Built once per scene (not per pose)."""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from puppet.errors import SceneError
from puppet.geom.contour import mask_regions, subdivide_segment
from puppet.geom.merge import GroupMesh, UnionFind, merge_meshes
from puppet.geom.triangulate import (
    MAX_TRIANGLES,
    Mesh,
    MeshTooLarge,
    edge_length_for_area,
    triangulate_regions,
)
from puppet.imaging import masks as mk
from puppet.imaging.inpaint import inpaint_layer
from puppet.imaging.io import load_mask_image, load_rgba
from puppet.scene.format.model import Layer, SceneData
from puppet.scene.format.video import start_frame
from puppet.scene.rig.links import LinkParts, coupling

#: Default meshes aim at about this many triangles per layer.
TARGET_TRIANGLES = 2000


@dataclass
class LayerImage:
    """A layer's pixels: its RGBA image (straight alpha, already masked and inpainted),
    where it sits on the canvas, and its mask in the image's pixel grid."""

    rgba: np.ndarray
    offset: tuple[float, float]
    mask: np.ndarray
    from_source: bool

    def contains(self, xy) -> bool:
        """Is canvas point ``xy`` on a mask pixel?"""
        j = int(np.floor(xy[0] - self.offset[0]))
        i = int(np.floor(xy[1] - self.offset[1]))
        h, w = self.mask.shape
        return 0 <= i < h and 0 <= j < w and bool(self.mask[i, j])

    @functools.cached_property
    def drawn(self) -> tuple[np.ndarray, tuple[float, float]]:
        """The part of ``rgba`` a texture needs, and its canvas offset: the box of the
        pixels of nonzero alpha with one transparent pixel around it. Sampling clamped to
        the edge reads the same zeros beyond that border as the whole image holds there,
        so the same pixels are drawn from a smaller upload (a T-rex part covers 0.4-10 %
        of its 600x500 image). The same array object on every call (textures are cached
        by it)."""
        import cv2

        x, y, w, h = cv2.boundingRect((self.rgba[..., 3] > 0).view(np.uint8))
        if w == 0:
            return self.rgba, self.offset
        H, W = self.rgba.shape[:2]
        x0, y0, x1, y1 = max(x - 1, 0), max(y - 1, 0), min(x + w + 1, W), min(y + h + 1, H)
        return self.rgba[y0:y1, x0:x1], (self.offset[0] + x0, self.offset[1] + y0)


def reduced_rgba(rgba: np.ndarray, factor: float) -> np.ndarray:
    """A straight-alpha RGBA image (h, w, 4) uint8 shrunk ``factor`` times (area
    average of the premultiplied colours, so transparent pixels do not darken the edges):
    (ceil(h / factor), ceil(w / factor), 4) uint8."""
    import cv2

    h, w = rgba.shape[:2]
    size = (max(1, int(np.ceil(w / factor))), max(1, int(np.ceil(h / factor))))
    prem = rgba.copy()
    prem[..., :3] = (rgba[..., :3].astype(np.uint16) * rgba[..., 3:4] + 127) // 255
    small = cv2.resize(prem, size, interpolation=cv2.INTER_AREA)
    a = small[..., 3:4].astype(np.float32)
    rgb = np.where(a > 0, small[..., :3] * (255.0 / np.maximum(a, 1.0)), 0.0)
    small[..., :3] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    return small


@dataclass
class Group:
    """Linked layers solved as one problem."""

    layers: list[int]
    mesh: GroupMesh
    pins: list[int] = field(default_factory=list)  # indices into scene pins (interior pins)
    b: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # group vertex per pin
    couple: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))  # spring vertex pairs
    kappa: np.ndarray = field(default_factory=lambda: np.zeros(0))  # their weights (links of strength < 1)
    hinges: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))  # link points: vertex per side
    pin_part: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # local layer of each pin


def _image_and_mask(data: SceneData, L: Layer, source) -> LayerImage:
    base = f"layers[{L.index}]"
    if L.image is not None:
        rgba = load_rgba(L.image, scene_file=data.file, json_path=f"{base}.image")
    else:
        rgba = source
    shape = rgba.shape[:2]
    M = L.mask
    mp = f"{base}.mask"
    if M is None:
        mask = mk.alpha_mask(rgba) if mk.has_transparency(rgba) else mk.threshold_mask(rgba, 250.0)
    elif M.kind == "alpha":
        mask = mk.alpha_mask(rgba)
    elif M.kind == "threshold":
        mask = mk.threshold_mask(rgba, M.threshold, M.invert)
    elif M.kind == "polygon":
        mask = mk.polygon_mask(shape, M.polygon, L.offset) & (rgba[..., 3] > 0)
    elif M.kind == "rect":
        mask = mk.rect_mask(shape, M.rect, L.offset) & (rgba[..., 3] > 0)
    elif M.kind == "grabcut":
        mask = mk.grabcut_mask(rgba, M.rect, L.offset) & (rgba[..., 3] > 0)
    else:
        mask = load_mask_image(M.file, scene_file=data.file, json_path=f"{mp}.file")
        if mask.shape != shape:
            raise SceneError(f"mask file is {mask.shape[1]}x{mask.shape[0]} but the layer image is "
                             f"{shape[1]}x{shape[0]}", file=data.file, path=f"{mp}.file")
        mask &= rgba[..., 3] > 0
    if not mask.any():
        raise SceneError(f"the mask of layer {L.name!r} selects no pixels", file=data.file,
                         path=mp if L.mask is not None else base)
    return LayerImage(rgba=rgba, offset=L.offset, mask=mask, from_source=L.image is None)


def stacking(data: SceneData) -> list[int]:
    """Stacking index (rank, 0 = back) of each layer: by ``order``, then list position."""
    key = sorted(range(len(data.layers)),
                 key=lambda i: (data.layers[i].order if data.layers[i].order is not None else i, i))
    rank = [0] * len(key)
    for r, i in enumerate(key):
        rank[i] = r
    return rank


def load_source(data: SceneData):
    """The scene's template image (RGBA), or None."""
    if data.source is None:
        return None
    if data.video is not None:  # a video scene: its start frame
        return start_frame(data)
    return load_rgba(data.source, scene_file=data.file, json_path="source")


def layer_image(data: SceneData, L: Layer, source) -> LayerImage:
    """One layer's pixels and mask, before inpainting and masking (see :func:`finish_image`)."""
    return _image_and_mask(data, L, source)


def inpaint_hole(data: SceneData, images: list[LayerImage], k: int, rank: list[int]) -> np.ndarray | None:
    """Pixels of layer ``k`` taken by layers in front of it from the same source, or None."""
    L, im = data.layers[k], images[k]
    if L.inpaint == "none" or not im.from_source:
        return None
    hole = np.zeros_like(im.mask)
    for j, other in enumerate(images):
        if other.from_source and rank[j] > rank[k]:
            hole |= other.mask
    hole &= im.mask
    return hole if hole.any() else None


def finish_image(im: LayerImage, hole: np.ndarray | None, method: str) -> LayerImage:
    """A new LayerImage refilled where ``hole`` is (by ``method``), alpha zero off the mask."""
    rgba = inpaint_layer(im.rgba, im.mask, hole, method) if hole is not None else im.rgba.copy()
    rgba[..., 3] = np.where(im.mask, rgba[..., 3], 0)
    return LayerImage(rgba=rgba, offset=im.offset, mask=im.mask, from_source=im.from_source)


def default_max_area(mask: np.ndarray) -> float:
    """Triangle area giving about TARGET_TRIANGLES triangles, within [6, 400] px²."""
    return float(np.clip(mask.sum() / TARGET_TRIANGLES, 6.0, 400.0))


def link_polylines(data: SceneData, areas: list[float], parts=None) -> list[list[tuple[int, str, np.ndarray]]]:
    """Per layer, its link parts as (link index, JSON path, (p, 2) points): each segment
    (clipped, polygon edges included; ``parts`` from :func:`puppet.scene.rig.links.link_parts`,
    the links' own segments when None) subdivided once with the finer spacing of its two
    layers (so both meshes share them), each hinge point as a (1, 2) array."""
    index = {L.name: L.index for L in data.layers}
    if parts is None:
        parts = LinkParts(segments=[(li, f"links[{li}].segments[{si}]", s) for li, link in enumerate(data.links)
                                    for si, s in enumerate(link.segments)])
    polylines: list[list[tuple[int, str, np.ndarray]]] = [[] for _ in data.layers]
    for li, path, seg in parts.segments:
        link = data.links[li]
        a, b = index[link.layers[0]], index[link.layers[1]]
        h = min(edge_length_for_area(areas[a]), edge_length_for_area(areas[b]))
        n = float(np.linalg.norm(seg[1] - seg[0])) / h  # bounded before allocating
        if n > MAX_TRIANGLES:
            raise SceneError(f"segment would be split into {n:,.0f} mesh edges at this density (at most "
                             f"{MAX_TRIANGLES:,})", file=data.file, path=path)
        P = subdivide_segment(seg[0], seg[1], h)
        polylines[a].append((li, path, P))
        polylines[b].append((li, path, P))
    for li, path, q in parts.points:
        link = data.links[li]
        for name in link.layers:
            polylines[index[name]].append((li, path, np.asarray(q, np.float64).reshape(1, 2)))
    return polylines


def layer_pins(data: SceneData, k: int) -> list[tuple[int, object]]:
    """(scene pin index, pin) of the interior pins on layer ``k``."""
    name = data.layers[k].name
    return [(i, p) for i, p in enumerate(data.pins) if p.layer == name and p.kind == "interior"]


def mesh_layer(data: SceneData, k: int, im: LayerImage, area: float,
               polylines: list[tuple[int, str, np.ndarray]], regions=None) -> Mesh:
    """Triangulate layer ``k``: its mask outline (``regions``, from the mask when None),
    its pins and link points as vertices, its link segments (already clipped to the
    overlap, :mod:`puppet.scene.rig.links`) as edges."""
    L = data.layers[k]
    pins = layer_pins(data, k)
    for i, p in pins:
        if not im.contains(p.at):
            on = f" on frame {data.video['start']}" if data.video is not None and im.from_source else ""
            raise SceneError(f"pin {p.name!r} at ({p.at[0]:g}, {p.at[1]:g}) is outside the mask of layer "
                             f"{L.name!r}{on}", file=data.file, path=f"pins[{i}].at")
    if regions is None:
        regions = mask_regions(im.mask, im.offset)
    hinges = [P[0] for _, _, P in polylines if len(P) == 1]
    pts = np.array([p.at for _, p in pins] + hinges).reshape(-1, 2)
    try:
        mesh = triangulate_regions(regions, max_area=area, min_angle=L.mesh.min_angle,
                                   simplify=L.mesh.simplify, points=pts,
                                   segments=[P for _, _, P in polylines if len(P) > 1])
    except MeshTooLarge as e:  # estimated before Triangle runs
        given = L.mesh.max_area is not None
        raise SceneError(str(e) if given else f"the default mesh would be too large: {e}", file=data.file,
                         path=f"layers[{k}].mesh.max_area" if given else f"layers[{k}]") from None
    if len(mesh.F) == 0:
        raise SceneError(f"layer {L.name!r} is too small to mesh", file=data.file, path=f"layers[{k}]")
    return mesh


def stand_in_mesh(im: LayerImage) -> Mesh:
    """The mesh of a hidden layer that nothing rigs (no pin, no link): two triangles over
    its mask's box, so that it costs nothing to build (a hidden sketch of thin lines meshed
    to 72k vertices, 2 s an open) and, never drawn and never moved, shows nothing wrong;
    showing the layer meshes it for real (:func:`mesh_layer`)."""
    rows, cols = np.flatnonzero(im.mask.any(axis=1)), np.flatnonzero(im.mask.any(axis=0))
    x0, y0 = float(im.offset[0] + cols[0]), float(im.offset[1] + rows[0])
    x1, y1 = float(im.offset[0] + cols[-1] + 1), float(im.offset[1] + rows[-1] + 1)
    V = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    return Mesh(V, np.array([[0, 3, 2], [0, 2, 1]], np.int32))


def pin_vertices(data: SceneData, k: int, mesh: Mesh) -> dict[str, int]:
    """Interior pin name -> vertex index in layer ``k``'s mesh."""
    found = {}
    for i, p in layer_pins(data, k):
        v = _vertex_at(mesh.V, p.at)
        if v is None:
            raise SceneError(f"pin {p.name!r} could not be placed in the mesh of layer {data.layers[k].name!r} "
                             "(too close to the edge?)", file=data.file, path=f"pins[{i}].at")
        found[p.name] = v
    return found


def layer_areas(data: SceneData, images: list[LayerImage]) -> list[float]:
    """Triangle area bound of every layer: its ``mesh.max_area`` or one from its size."""
    return [L.mesh.max_area or default_max_area(im.mask) for L, im in zip(data.layers, images)]


def _vertex_at(V: np.ndarray, xy, tol: float = 1e-7):
    d = np.linalg.norm(V - np.asarray(xy)[None], axis=1)
    k = int(np.argmin(d)) if len(d) else -1
    return k if k >= 0 and d[k] <= tol else None


def build_groups(data: SceneData, meshes, pin_vertex, polylines) -> list[Group]:
    """Linked groups: union of linked layers, their merged mesh, pins and pinned vertices."""
    n = len(data.layers)
    index = {L.name: L.index for L in data.layers}
    uf = UnionFind(n)
    for link in data.links:
        uf.union(index[link.layers[0]], index[link.layers[1]])
    lab = uf.labels()
    groups = []
    for g in range(lab.max() + 1):
        members = [k for k in range(n) if lab[k] == g]
        local = {k: i for i, k in enumerate(members)}
        shared, springs = [], []
        for li, link in enumerate(data.links):
            a, b = index[link.layers[0]], index[link.layers[1]]
            if a not in local:
                continue
            for (l2, path, P) in polylines[a]:
                if l2 != li:
                    continue
                for q in P:
                    va, vb = _vertex_at(meshes[a].V, q), _vertex_at(meshes[b].V, q)
                    if va is None or vb is None:
                        raise SceneError("link could not be meshed in both layers (is it too close "
                                         "to an edge?)", file=data.file, path=path)
                    (shared if link.strength >= 1.0 else springs).append((local[a], va, local[b], vb, li, len(P) == 1))
        gm = merge_meshes([(meshes[k].V, meshes[k].F) for k in members], [s[:4] for s in shared])
        grp = Group(layers=members, mesh=gm)
        merged = np.unique(np.array([int(gm.maps[la][va]) for la, va, lb, vb, li, one in shared if one], np.int64))
        split = [(int(gm.maps[la][va]), int(gm.maps[lb][vb])) for la, va, lb, vb, li, one in springs if one]
        grp.hinges = np.array([(v, v) for v in merged] + split, np.int64).reshape(-1, 2)
        if springs:
            pairs = {(int(gm.maps[la][va]), int(gm.maps[lb][vb])): coupling(data.links[li].strength)
                     for la, va, lb, vb, li, _ in springs}
            pairs = {ab: w for ab, w in pairs.items() if ab[0] != ab[1] and w > 0}
            grp.couple = np.array(list(pairs), np.int64).reshape(-1, 2)
            grp.kappa = np.array(list(pairs.values()), np.float64)
        seen = {}
        for i, p in enumerate(data.pins):
            if p.kind != "interior" or index[p.layer] not in local:
                continue
            v = int(gm.maps[local[index[p.layer]]][pin_vertex[index[p.layer]][p.name]])
            if v in seen:
                raise SceneError(f"pin {p.name!r} is on the same point as pin {data.pins[seen[v]].name!r}",
                                 file=data.file, path=f"pins[{i}].at")
            seen[v] = i
            grp.pins.append(i)
        grp.b = np.array([int(gm.maps[local[index[data.pins[i].layer]]][pin_vertex[index[data.pins[i].layer]]
                                                                          [data.pins[i].name]])
                          for i in grp.pins], np.int64)
        grp.pin_part = np.array([local[index[data.pins[i].layer]] for i in grp.pins], np.int64)
        groups.append(grp)
    return groups
