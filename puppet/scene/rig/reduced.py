"""A reduced model of a linked group for drag previews: the same layers meshed coarser,
merged and precomputed by the same code as the fine group, solved as an exact pose is
(:func:`~puppet.scene.rig.solve.solve_group`) while the pointer moves, and drawn in the
fine layers' place, plus a detail residual kept from the drag's start.

Every layer of the group is meshed again with bigger triangles (about
:data:`REDUCED_VERTICES` vertices for the whole group), with the same pins, hinge points
and link segments as vertices and edges (:func:`~puppet.scene.rig.build.mesh_layer`), and
with the fine mesh's own vertices around every pin and hinge point, graded out to the
coarse size (:func:`_grading`: how far a point handle's neighbourhood stretches depends on
the mesh there). The coarse layers are merged by :func:`~puppet.scene.rig.build.build_groups`
and precomputed by :func:`~puppet.scene.rig.solve.precompute_group` with their own cells
(:func:`~puppet.scene.rig.stiffness.group_cells`): modes, painted stiffness, starch pins,
patches (``couple``) and hinges come with the same code as the fine group's.

Barycentric coordinates carry vertices between the two (:func:`barycentric_matrix`, each
vertex in its own layer's mesh, extrapolated outside it): ``B`` fine from coarse, ``C``
coarse from fine. The coarse and the exact fine pose differ by a detail residual, known at
the drag's start (the exact start pose is on the screen anyway): ``C @ U_exact - U_coarse``
at the coarse vertices, kept in each coarse vertex's rest frame and added back turned by
its current rotation (:func:`residual`, :func:`detailed`).

The model is a pure function of (built, group): :func:`reduced_for` keeps it in the rig's
memo under a fingerprint of the group's precomputation key and the model's settings.
docs/algorithms.md ("Reduced model for drag previews") gives its error, measured.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from puppet.deform.boundary import exterior_positions
from puppet.deform.relax import relax_foldovers
from puppet.errors import SceneError
from puppet.geom.triangulate import edge_length_for_area
from puppet.scene.rig import build
from puppet.scene.rig.cache import fingerprint
from puppet.scene.rig.core import LayerResult
from puppet.scene.rig.exterior import GroupExterior
from puppet.scene.rig.links import link_parts
from puppet.scene.rig.solve import GroupPose, GroupPre, precompute_group, solve_group
from puppet.scene.rig.stiffness import group_cells

#: Work units (ARAP iterations of the coarse mesh) the fold relaxation of a preview
#: frame may spend (an exact pose: ``puppet.deform.relax.BUDGET`` and more on small meshes).
PREVIEW_RELAX = 40.0
#: Groups with more vertices than this are previewed on a reduced model (smaller ones
#: are solved exactly on their own mesh, which costs no more).
REDUCED_MIN = 12000
#: About how many vertices a group's reduced model has.
REDUCED_VERTICES = 2000
#: Nearest coarse triangles (by centroid) searched for the one holding a fine vertex.
CANDIDATES = 8
#: Grading around pins: fine vertices kept within NEAR fine edge lengths, then rings of
#: RING points, each RATIO times farther out.
NEAR, RATIO, RING = 2.5, 1.5, 8
#: A model with more than this share of the fine group's vertices is not used (it would
#: save too little: many pins, each graded).
MAX_SHARE = 0.5
#: A detail residual smaller than this everywhere (px) is not added.
NO_DETAIL = 1e-6
_NO_EXTERIOR = GroupExterior()


@dataclass
class Reduced:
    """The coarse group of one fine group and how the two carry each other's vertices."""

    group: build.Group  # coarse group: pins in the fine group's order
    pre: GroupPre
    meshes: list  # per group layer (fine group order): its coarse layer mesh
    pins: list[dict[str, int]]  # per group layer: interior pin name -> coarse layer vertex
    B: sp.csr_matrix  # (n_fine, n_coarse): fine vertices in coarse triangles (barycentric)
    C: sp.csr_matrix  # (n_coarse, n_fine): coarse vertices in fine triangles (barycentric)
    around: sp.csr_matrix  # (n_coarse, m_coarse): areas of the triangles around each coarse vertex
    rest_inv: np.ndarray  # (m, 2, 2) inverse rest edge matrix of each coarse triangle


def _tree(points):
    """A k-d tree of ``points``."""
    from scipy.spatial import cKDTree  # lazy: scipy.spatial costs 0.17 s of every command's start-up

    return cKDTree(points)


def reduced_for(rig, built, gi: int) -> Reduced | None:
    """The reduced model of group ``gi`` (built once per group version, kept in the rig's
    memo), or None when the group is small, has no pins, is not solved by ARAP, or cannot
    be meshed coarser (it is then previewed on its own mesh)."""
    g, d = built.groups[gi], built.data.deformer
    if len(g.mesh.V) <= REDUCED_MIN or not len(g.pins) or d.method != "arap":
        return None
    key = fingerprint("reduced", built.pre_keys[gi], REDUCED_VERTICES, NEAR, RATIO, RING, MAX_SHARE)
    return rig.memo.get("reduced model", key,
                        lambda: build_reduced(built, gi, REDUCED_VERTICES))


def build_reduced(built, gi: int, vertices: int) -> Reduced | None:
    """The reduced model of group ``gi`` with about ``vertices`` vertices plus the grading
    around pins (a pure function of ``built``), or None when a coarse mesh cannot be made
    or would have more than :data:`MAX_SHARE` of the fine group's vertices."""
    g, data = built.groups[gi], built.data
    sub = _coarse_data(data, g, len(g.mesh.V) / vertices, built)
    images = [built.images[k] for k in g.layers]
    try:
        meshes, pin_vertex, polylines = _coarse_layers(built, g, sub, images)
        groups = build.build_groups(sub, meshes, pin_vertex, polylines)
    except (SceneError, ValueError):  # (MeshTooLarge is a ValueError)
        return None
    if len(groups) != 1 or len(groups[0].pins) != len(g.pins):
        return None
    if len(groups[0].mesh.V) > MAX_SHARE * len(g.mesh.V):
        return None
    cg = groups[0]
    pre = precompute_group(cg, data.deformer, np.zeros((0, 2), np.int64), group_cells(sub, images, cg, meshes))
    V, F = cg.mesh.V, cg.mesh.F
    T = V[F]
    E = np.stack([T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]], axis=2)  # (m, 2, 2): edges as columns
    area = np.abs(np.linalg.det(E)) / 2
    around = sp.csr_matrix((np.repeat(area, 3), (F.ravel(), np.repeat(np.arange(len(F)), 3))),
                           shape=(len(V), len(F)))
    fine = [built.meshes[k] for k in g.layers]
    return Reduced(group=cg, pre=pre, meshes=meshes, pins=pin_vertex, B=_carry(g.mesh, meshes, cg.mesh),
                   C=_carry(cg.mesh, fine, g.mesh), around=around, rest_inv=np.linalg.inv(E))


def _coarse_layers(built, g, sub, images):
    """The coarse layer meshes of group ``g`` (``sub``: the scene cut down to it), their
    pin vertices and link polylines."""
    parts = link_parts(sub, images)
    areas = build.layer_areas(sub, images)
    polylines = build.link_polylines(sub, areas, parts)
    fine = build.layer_areas(built.data, built.images)
    meshes = [build.mesh_layer(sub, i, images[i], areas[i], polylines[i] + _grading(
        sub, i, images[i], polylines[i], built.meshes[k], fine[k], areas[i]), built.regions[k])
        for i, k in enumerate(g.layers)]
    return meshes, [build.pin_vertices(sub, i, m) for i, m in enumerate(meshes)], polylines


def _grading(data, k: int, im, polylines, fine_mesh, fine: float, coarse: float) -> list:
    """Extra mesh points around the pins and hinge points of layer ``k``, as
    (-1, "", (1, 2) point) entries of its polylines: the fine mesh's own vertices within
    :data:`NEAR` fine edge lengths h, then rings of :data:`RING` points at radii growing
    :data:`RATIO` times up to the coarse edge length. A pinned vertex's neighbourhood
    stretches by an amount that depends on the mesh there (a point handle is singular in
    the continuous problem), so the coarse mesh copies the fine one where a pin pulls."""
    h, top = edge_length_for_area(fine), edge_length_for_area(coarse)
    centres = np.array([p.at for _, p in build.layer_pins(data, k)] + [P[0] for _, _, P in polylines if len(P) == 1],
                       float).reshape(-1, 2)
    if not len(centres):
        return []
    near = np.unique(np.concatenate([np.asarray(i, np.int64) for i in
                                     _tree(fine_mesh.V).query_ball_point(centres, NEAR * h)]))
    pts = [fine_mesh.V[near]]
    n_rings = max(0, int(np.ceil(np.log(max(top / (NEAR * h), 1.0)) / np.log(RATIO))))
    ang = np.linspace(0, 2 * np.pi, RING, endpoint=False)
    for j in range(1, n_rings + 1):
        a, r = ang + j * np.pi / RING, NEAR * h * RATIO ** j
        pts.append((centres[:, None, :] + r * np.stack([np.cos(a), np.sin(a)], 1)[None]).reshape(-1, 2))
    pts = np.concatenate(pts)
    fixed = np.concatenate([centres] + [P for _, _, P in polylines]).reshape(-1, 2)
    keep = _tree(fixed).query(pts)[0] > 0.3 * h  # not onto a pin, hinge or link vertex
    return [(-1, "", q.reshape(1, 2)) for q in pts[keep] if im.contains(q)]


def _coarse_data(data, g, factor: float, built):
    """The scene restricted to group ``g``'s layers (renumbered), each meshed ``factor``
    times coarser, its outline simplified to an eighth of the coarse edge length."""
    names = {data.layers[k].name for k in g.layers}
    layers = []
    for i, k in enumerate(g.layers):
        L = data.layers[k]
        area = (L.mesh.max_area or build.default_max_area(built.images[k].mask)) * factor
        mesh = dataclasses.replace(L.mesh, max_area=area,
                                   simplify=max(L.mesh.simplify, edge_length_for_area(area) / 8))
        layers.append(dataclasses.replace(L, index=i, mesh=mesh))
    return dataclasses.replace(
        data, layers=layers, links=[k for k in data.links if k.layers[0] in names],
        pins=[p for p in data.pins if p.layer in names and p.kind != "exterior"], bones=[])


def _carry(src, meshes, dst) -> sp.csr_matrix:
    """(n_src, n_dst) barycentric coordinates of the vertices of group mesh ``src`` in the
    layer meshes ``meshes`` of group mesh ``dst`` (same layers, same order), each vertex
    in its own layer's mesh (:func:`barycentric_matrix`)."""
    rows, cols, vals = [], [], []
    for li, m in enumerate(meshes):
        W = barycentric_matrix(src.V[src.maps[li]], m.V, m.F).tocoo()
        rows.append(src.maps[li][W.row])
        cols.append(dst.maps[li][W.col])
        vals.append(W.data)
    n, nd = len(src.V), len(dst.V)
    W = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, nd))
    return _one_row_each(W.tocsr(), [src.maps[li] for li in range(len(meshes))])


def _one_row_each(W: sp.csr_matrix, maps) -> sp.csr_matrix:
    """``W`` with the rows of vertices shared by several layers (merged along a link, so
    carried by each of those layers' meshes) averaged: every row sums to one."""
    counts = np.zeros(W.shape[0], np.int64)
    for m in maps:
        counts[m] += 1
    if counts.max(initial=0) <= 1:
        return W
    return (sp.diags(1.0 / np.maximum(counts, 1)) @ W).tocsr()


def barycentric_matrix(P: np.ndarray, V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """(p, n) barycentric coordinates of points ``P`` (p, 2) in the triangle mesh (V, F)
    that holds each, or for a point outside the mesh, in the triangle (of the
    :data:`CANDIDATES` nearest by centroid) it is least outside of (extrapolated). A
    linear function of V is carried exactly: ``W @ (V A + t) = P A + t``."""
    T = V[F]  # (m, 3, 2)
    _, cand = _tree(T.mean(axis=1)).query(P, k=min(CANDIDATES, len(F)))
    cand = cand.reshape(len(P), -1)
    lam = _barycentric(T[cand], P[:, None, :])  # (p, c, 3)
    best = np.argmax(lam.min(axis=2), axis=1)
    t = cand[np.arange(len(P)), best]
    rows = np.repeat(np.arange(len(P)), 3)
    return sp.csr_matrix((lam[np.arange(len(P)), best].ravel(), (rows, F[t].ravel())), shape=(len(P), len(V)))


def _barycentric(T: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (..., 3) of points P (..., 2) in triangles T (..., 3, 2)."""
    a, b, c = T[..., 0, :], T[..., 1, :], T[..., 2, :]
    v0, v1, v2 = b - a, c - a, P - a
    den = v0[..., 0] * v1[..., 1] - v1[..., 0] * v0[..., 1]
    den = np.where(np.abs(den) > 1e-300, den, 1e-300)
    l1 = (v2[..., 0] * v1[..., 1] - v1[..., 0] * v2[..., 1]) / den
    l2 = (v0[..., 0] * v2[..., 1] - v2[..., 0] * v0[..., 1]) / den
    return np.stack([1.0 - l1 - l2, l1, l2], axis=-1)


def reduced_solve(red: Reduced, deformer, pose: GroupPose) -> tuple[np.ndarray, np.ndarray]:
    """Coarse vertices (n_c, 2) and pin-depth field (n_c,) of the reduced model in
    ``pose``: the same solve as an exact pose (exterior points aside), but a fold
    relaxation of at most :data:`PREVIEW_RELAX` work units (an exact pose may spend
    seven plain solves on it: a far drag that folds the coarse mesh would cost a preview
    frame 5-8 times an unfolded one)."""
    ext = np.zeros((0, 2))
    plain = dataclasses.replace(deformer, relax_foldovers=False)
    U, depth, _ = solve_group(red.pre, red.group, plain, _NO_EXTERIOR, dataclasses.replace(pose, ext_to=ext))
    if deformer.relax_foldovers and deformer.method == "arap" and len(red.group.pins):
        U = relax_foldovers(red.pre.arap, U, pose.bc, budget=PREVIEW_RELAX)
    return U, depth


def rotations(red: Reduced, Uc: np.ndarray) -> np.ndarray:
    """(n_c, 2, 2) rotation of the deformed coarse mesh ``Uc`` at every coarse vertex: the
    closest rotation to the area-weighted mean deformation gradient of its triangles."""
    T = Uc[red.group.mesh.F]
    J = (np.stack([T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]], axis=2) @ red.rest_inv).reshape(-1, 4)
    J = red.around @ J
    c, s = J[:, 0] + J[:, 3], J[:, 2] - J[:, 1]
    r = np.hypot(c, s)
    ok = r > 0
    r = np.where(ok, r, 1.0)
    c, s = np.where(ok, c / r, 1.0), np.where(ok, s / r, 0.0)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def residual(red: Reduced, Uc: np.ndarray, U_exact: np.ndarray) -> np.ndarray | None:
    """The detail residual (n_c, 2) of the exact fine pose ``U_exact`` at the coarse
    vertices against the coarse pose ``Uc``, in each coarse vertex's rest frame; None
    where it is below :data:`NO_DETAIL` px everywhere (a drag from the rest pose, where
    both are the rest mesh)."""
    r = red.C @ U_exact - Uc
    if not np.abs(r).max(initial=0.0) > NO_DETAIL:
        return None
    return np.einsum("nji,nj->ni", rotations(red, Uc), r)


def detailed(red: Reduced, Uc: np.ndarray, detail: np.ndarray | None) -> np.ndarray:
    """The coarse pose ``Uc`` (n_c, 2) with the ``detail`` residual (from :func:`residual`)
    turned by each coarse vertex's rotation."""
    if detail is None:
        return Uc
    return Uc + np.einsum("nij,nj->ni", rotations(red, Uc), detail)


def reduced_layers(red: Reduced, built, gi: int, U: np.ndarray, depth: np.ndarray) -> dict:
    """{scene layer: :class:`~puppet.scene.rig.core.LayerResult`} of the group drawn as its
    posed coarse meshes (``U`` (n_c, 2), ``depth`` (n_c,)): texture coordinates from their
    rest positions, as for any layer; exterior points ride on the fine vertices carried
    from the coarse ones."""
    g, data, ge = built.groups[gi], built.data, built.exterior[gi]
    ext = exterior_positions(red.B @ U, ge.frame) if ge.frame is not None else np.zeros((0, 2))
    out = {}
    for li, (k, m) in enumerate(zip(g.layers, red.meshes)):
        idx, r = red.group.mesh.maps[li], built.rank[k]
        exterior = {n: [float(x) for x in ext[j]] for j, n in enumerate(ge.names) if ge.layers[j] == k}
        out[k] = LayerResult(name=data.layers[k].name, group=gi, order=r, rest=m.V, deformed=U[idx],
                             triangles=m.F, depth=r + depth[idx], pins=dict(red.pins[li]), exterior=exterior,
                             key=built.image_keys[k])
    return out
