"""The rig: a scene built for posing. Layer images, layer meshes, linked groups, their
exterior points and solver precomputations, each built from exactly what it depends on
and cached under a fingerprint of that (see :mod:`puppet.scene.rig.cache`).

So an edit costs only what it must, by construction: a moved pin target re-solves only
its group; a changed pin set re-meshes the layer the pin is on (pins are mesh vertices)
and re-precomputes only its group; a changed mask, image, link or mesh option re-meshes
the layers it touches and re-precomputes their groups. Nothing is invalidated by hand.

The path of a pin from the scene file to the screen: ``SceneData.pins`` -> a vertex of
its layer's mesh (:func:`build.mesh_layer`) -> a vertex ``b`` of its group's merged mesh
(:func:`build.build_groups`) -> the group's solver (:mod:`puppet.scene.rig.solve`) ->
deformed vertices and depth per layer (:meth:`Rig.evaluate`) -> the compositor.
"""
from __future__ import annotations

import os
import threading
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from puppet.geom.contour import mask_regions
from puppet.scene.format.model import SceneData
from puppet.scene.rig import build
from puppet.scene.rig.cache import Memo, file_stamp, fingerprint
from puppet.scene.rig.exterior import GroupExterior, build_exterior
from puppet.scene.rig.links import link_parts
from puppet.scene.rig.solve import (
    GroupPose,
    GroupPre,
    PinState,
    precompute_group,
    solve_group,
)
from puppet.scene.rig.stiffness import group_cells

#: how many of each kind of built part are kept (least recently used dropped first); the
#: kinds of :data:`PER_LAYER` keep at least two per layer of the scene built last
CAPACITY = {"pixels": 16, "reduced": 64, "layer": 64, "image": 64, "mesh": 64, "outline": 64, "groups": 16, "exterior": 8, "precompute": 16, "solve": 64,
            "pose": 16, "cells": 16, "links": 8, "classes": 64,
            "cage": 64}

#: threads that read, mask and mesh the layers of a scene (the cores there are, at most 8)
WORKERS = min(8, os.cpu_count() or 1)

#: kinds of part built once per layer (or per group, at most one per layer)
PER_LAYER = ("layer", "image", "mesh", "outline", "reduced", "precompute", "solve", "cells", "classes", "cage")


@dataclass
class LayerResult:
    """One layer in one pose: what `puppet mesh` writes and the renderer draws."""

    name: str
    group: int
    order: int
    rest: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    depth: np.ndarray
    pins: dict[str, int]
    exterior: dict[str, list[float]]
    key: str = ""  # fingerprint of the layer's pixels (a renderer's texture identity)


@dataclass
class Built:
    """Everything one version of a scene needs for every pose."""

    data: SceneData
    rank: list[int]
    images: list[build.LayerImage]
    image_keys: list[str]
    meshes: list  # per layer: geom.triangulate.Mesh
    pin_vertex: list[dict[str, int]]
    groups: list[build.Group]
    exterior: list[GroupExterior]
    pre: list[GroupPre]
    pre_keys: list[str]
    notes: list[str] = field(default_factory=list)  # for `puppet check` (clipped link segments)
    regions: list = None  # per layer: its mask outline (geom.contour.mask_regions), as meshed
    cages: list = None  # per group: a LayerCage where its layer is caged, else None (None: no cage at all)

    def group_of_pin(self, i: int) -> int | None:
        """Group of scene pin ``i`` (None for exterior pins)."""
        return next((gi for gi, g in enumerate(self.groups) if i in g.pins), None)

    def ext_slices(self) -> list[slice]:
        starts = np.cumsum([0] + [len(ge.names) for ge in self.exterior])
        return [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]

    def group_pose(self, gi: int, state: PinState) -> GroupPose:
        g = self.groups[gi]
        return GroupPose(bc=state.to[g.pins].reshape(-1, 2), angle=state.angle[g.pins],
                         depth=state.depth[g.pins], ext_to=state.ext_to[self.ext_slices()[gi]])


class Rig:
    """Builds scenes into :class:`Built` parts and solves poses, caching by content.

    ``memo.count(kind)`` tells how many parts of a kind were really built: ``"mesh"``
    (layer triangulations), ``"precompute"`` (group factorisations), ``"solve"``.
    """

    def __init__(self, disk=None):
        self.memo = Memo(CAPACITY, disk=disk)
        self._shown: set[str] = set()  # group versions (pre keys) solved once in this rig
        self._warm = threading.local()  # this thread's starts of accelerated solves, by pre key

    # -- building ----------------------------------------------------------------
    def build(self, data: SceneData, *, lazy_pre: bool = False) -> Built:
        """The scene built; ``lazy_pre``: the groups' precomputations made (or read from the
        disk cache, with their factorisations) only when a solve first needs them, not now
        (a first frame whose pose the disk cache holds needs none of them)."""
        memo = self.memo
        memo.at_least(PER_LAYER, 2 * len(data.layers))
        rank = build.stacking(data)
        source = None
        if data.source is not None:
            source = memo.get("pixels", fingerprint(file_stamp(data.source)), lambda: build.load_source(data))
        base_keys = [fingerprint(file_stamp(L.image), file_stamp(data.source) if L.image is None else None,
                                 L.offset, L.mask, file_stamp(L.mask.file) if L.mask is not None else None)
                     for L in data.layers]
        # a layer's pixels before inpainting, read only where a finished image is not found
        bases = _Lazy(len(data.layers), lambda k: memo.get("layer", base_keys[k], lambda: build.layer_image(
            data, data.layers[k], source)))
        image_keys = []
        for k, L in enumerate(data.layers):
            front = [base_keys[j] for j, M in enumerate(data.layers) if M.image is None and rank[j] > rank[k]]
            image_keys.append(fingerprint(base_keys[k], L.inpaint, front if L.inpaint != "none" else None))
        images = _parallel(len(data.layers), lambda k: memo.get("image", image_keys[k], lambda: build.finish_image(
            bases[k], build.inpaint_hole(data, bases, k, rank), data.layers[k].inpaint)))
        # the links clipped to the masks (a dilation per linked layer) and the layers' triangle
        # areas depend on the images and the links, not on a pose: kept, not redone every edit
        links_key = fingerprint(image_keys, [(L.name, L.mesh.max_area) for L in data.layers],
                                [(k.layers, k.segments, k.points, k.polygons) for k in data.links])
        areas, parts = memo.get("links", links_key, lambda: (build.layer_areas(data, images),
                                                               link_parts(data, images)))
        polylines = build.link_polylines(data, areas, parts)
        outlines = _parallel(len(data.layers), lambda k: memo.get("outline", base_keys[k], lambda: mask_regions(
            images[k].mask, images[k].offset)))
        mesh_keys, stand_in = [], []
        for k, L in enumerate(data.layers):
            pins = [p.at for _, p in build.layer_pins(data, k)]
            segs = [(path, P) for li, path, P in polylines[k]]
            stand_in.append(not L.visible and not pins and not segs and L.exterior is None
                            and L.cage is None)  # nothing rigs it
            mesh_keys.append(fingerprint(base_keys[k], L.mesh, areas[k], pins, segs, stand_in[k]))
        meshes = _parallel(len(data.layers), lambda k: memo.get("mesh", mesh_keys[k], lambda: (
            build.stand_in_mesh(images[k]) if stand_in[k] else
            build.mesh_layer(data, k, images[k], areas[k], polylines[k], outlines[k]))))
        pin_vertex = [build.pin_vertices(data, k, mesh) for k, mesh in enumerate(meshes)]
        groups_key = fingerprint(mesh_keys, [(k.layers, k.segments) + _link_extra(k) for k in data.links],
                                 [(p.name, p.layer, p.at, p.kind) for p in data.pins])
        groups = memo.get("groups", groups_key, lambda: build.build_groups(data, meshes, pin_vertex, polylines))
        group_keys = [fingerprint([mesh_keys[k] for k in g.layers], g.mesh.V.shape, g.b) for g in groups]
        cages = self._cages(data, images, groups, group_keys, base_keys)
        rests = {lc.layer: lc.rest for lc in cages or () if lc is not None}
        ext_key = fingerprint(group_keys, [(L.exterior, base_keys[k]) for k, L in enumerate(data.layers)],
                              [(p.name, p.layer, p.at) for p in data.pins if p.kind == "exterior"],
                              {n: sorted(pose) for n, pose in data.poses.items()}, *([rests] if rests else []))
        exterior = memo.get("exterior", ext_key, lambda: build_exterior(data, images, groups, rests)[0])
        d = data.deformer
        pre_keys, made = [], []
        for gi, g in enumerate(groups):
            bones = _group_bones(data, g)
            ckey = fingerprint(group_keys[gi], d.mode, [(data.layers[k].mode, data.layers[k].stiffness and file_stamp(
                data.layers[k].stiffness)) for k in g.layers], [(p.layer, p.at, p.radius) for p in data.pins
                                                                  if p.kind == "starch"],
                               [(k.layers, k.polygons) for k in data.links if k.polygons])
            cells = memo.get("cells", ckey, lambda g=g: group_cells(data, images, g, meshes))
            pre_keys.append(fingerprint(group_keys[gi], d.method, d.weights, d.alpha,
                                        bones if d.method == "mls-skeleton" else 0, *_cells_key(d, cells, g)))
            made.append(lambda g=g, bones=bones, cells=cells: precompute_group(g, d, bones, cells))
        # groups are independent: factorised side by side (QDLDL and the sparse products release the GIL)
        def precompute():
            return _parallel(len(groups), lambda gi: memo.get("precompute", pre_keys[gi], made[gi]))
        pre = _AllLazy(len(groups), precompute) if lazy_pre else precompute()
        return Built(data=data, rank=rank, images=images, image_keys=image_keys, meshes=meshes,
                     pin_vertex=pin_vertex, groups=groups, exterior=exterior, pre=pre, pre_keys=pre_keys,
                     notes=parts.notes, regions=outlines, cages=cages)

    def _cages(self, data: SceneData, images, groups, group_keys, base_keys) -> list | None:
        """Per group, the :class:`~puppet.scene.rig.cages.LayerCage` of its caged layer
        (None for an uncaged group); None where the scene has no cage. Kept in memory only
        (not a disk-cache kind)."""
        if not any(L.cage for L in data.layers):
            return None
        from puppet.scene.rig.cages import build_cage, rest_cage  # lazy: scipy.linalg, for caged scenes only

        out = []
        for gi, g in enumerate(groups):
            k = next((k for k in g.layers if data.layers[k].cage), None)
            if k is None:
                out.append(None)
                continue
            key = fingerprint(k, group_keys[gi], data.layers[k].cage, base_keys[k], [data.pins[i].at for i in g.pins])
            out.append(self.memo.get("cage", key, lambda k=k, g=g: build_cage(
                data, k, rest_cage(data, k, images[k]), g)))
        return out

    # -- posing ------------------------------------------------------------------
    def solve(self, built: Built, gi: int, state: PinState):
        """(U, depth, exterior positions) of group ``gi`` in ``state``: exact, cached by content.

        The first solve of a group version in this rig (the pose a scene opens with) is
        also kept on disk (kind ``"pose"``), so a second open does not solve it again;
        later ones (drags, animation frames) stay in memory only. A warm-started solve
        is never read from nor written to disk."""
        d = built.data.deformer
        gp = built.group_pose(gi, state)
        cage = built.cages[gi] if built.cages else None
        key = fingerprint(built.pre_keys[gi], d, gp, [(ge.names, ge.rest) for ge in built.exterior[gi:gi + 1]],
                          *([cage.rest, cage.cmap.kind] if cage else []))
        warm = getattr(self._warm, "starts", {}).get(built.pre_keys[gi])

        def exact():
            if cage is not None:
                from puppet.scene.rig.cages import cage_solve  # lazy: scipy.linalg, for caged scenes only

                return cage_solve(cage, built.pre[gi], built.groups[gi], d, built.exterior[gi], gp)
            return solve_group(built.pre[gi], built.groups[gi], d, built.exterior[gi], gp, warm=warm)

        def first():
            shown = warm is None and built.pre_keys[gi] not in self._shown
            self._shown.add(built.pre_keys[gi])
            return self.memo.get("pose", key, exact) if shown else exact()
        return self.memo.get("solve", key, first)

    @contextmanager
    def warm_started(self, built: Built, starts: dict):
        """Inside (this thread): an exact solve of group ``gi`` of ``built``'s version that
        is not cached starts from ``starts[gi]`` (n, 2) (a drag's last preview) where the
        scene opts into an accelerated solve; the default loop ignores it."""
        self._warm.starts = {built.pre_keys[gi]: U for gi, U in starts.items()}
        try:
            yield
        finally:
            self._warm.starts = {}

    def evaluate(self, built: Built, state: PinState, solved: dict | None = None) -> list[LayerResult]:
        """Per-layer results of one pose, in scene layer order. ``solved`` may give some
        groups' (U, depth, exterior) already (a drag preview); the rest are solved exactly."""
        data = built.data
        out: list[LayerResult | None] = [None] * len(data.layers)
        for gi, g in enumerate(built.groups):
            U, depth, ext = solved[gi] if solved and gi in solved else self.solve(built, gi, state)
            ge = built.exterior[gi]
            for li, k in enumerate(g.layers):
                idx = g.mesh.maps[li]
                L, r = data.layers[k], built.rank[k]
                exterior = {n: [float(x) for x in ext[j]] for j, n in enumerate(ge.names) if ge.layers[j] == k}
                out[k] = LayerResult(name=L.name, group=gi, order=r, rest=built.meshes[k].V, deformed=U[idx],
                                     triangles=built.meshes[k].F, depth=r + depth[idx],
                                     pins=dict(built.pin_vertex[k]), exterior=exterior, key=built.image_keys[k])
        return out


def _parallel(n: int, make) -> list:
    """``[make(k) for k in range(n)]`` on a thread pool (decoding, masks and outlines
    release the GIL in OpenCV, zlib and numpy); the first failure in layer order raises,
    as in a loop."""
    workers = min(n, WORKERS)
    if workers < 2:
        return [make(k) for k in range(n)]
    with ThreadPoolExecutor(workers, thread_name_prefix="puppet-build") as pool:
        return list(pool.map(make, range(n)))


class _AllLazy(Sequence):
    """``n`` items, all made together (``make()`` -> list) on the first use of any (once,
    also from several threads)."""

    def __init__(self, n: int, make):
        self._n, self._make = n, make
        self._items: list | None = None
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, k):
        with self._lock:
            if self._items is None:
                self._items = list(self._make())
        return self._items[k]


class _Lazy(Sequence):
    """``n`` items, each made on first use (once, also from several threads)."""

    def __init__(self, n: int, make):
        self._make = make
        self._items: list = [None] * n
        self._made = [False] * n
        self._locks = [threading.Lock() for _ in range(n)]

    def __len__(self) -> int:
        return len(self._items)

    def __getitem__(self, k: int):
        if not 0 <= k < len(self._items):
            raise IndexError(k)
        with self._locks[k]:
            if not self._made[k]:
                self._items[k], self._made[k] = self._make(k), True
        return self._items[k]


def _link_extra(link) -> tuple:
    """The parts of a link besides its segments, () for a plain v1 link (same keys as before)."""
    if not link.points and not link.polygons and link.strength == 1.0:
        return ()
    return (link.points, link.polygons, link.strength)


def _cells_key(d, cells, g) -> tuple:
    """What of the cells' settings enters a group's precomputation, () when nothing does."""
    grey, modes = cells
    if grey is None and modes.count("rigid") == len(modes) and not len(g.couple):
        return ()
    return (grey, modes if d.method == "arap" else None, g.couple, g.kappa)


def _group_bones(data: SceneData, g: build.Group) -> np.ndarray:
    """The scene's bones between pins of group ``g``, as (nb, 2) indices into its pins."""
    local = {data.pins[i].name: k for k, i in enumerate(g.pins)}
    return np.array([(local[a], local[z]) for a, z in data.bones if a in local and z in local],
                    np.int64).reshape(-1, 2)
