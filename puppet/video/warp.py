"""One frame re-posed: skeleton MLS on a coarse grid over the frame's mask, resampled with
``cv2.remap`` and composited over the inpainted background.

Which way the map goes: the skeleton MLS (:mod:`puppet.deform.skeleton`) is a *forward*
map ``f``: a point ``v`` of the frame (the original character) goes to ``f(v)`` in the
re-posed picture. ``cv2.remap`` needs the *backward* map: for every output pixel, where
to read in the frame. So ``f`` is evaluated on the vertices of a grid mesh laid over the
character (every ``step`` px, interior distances along its edges, the joints as exact
vertices); the deformed triangles are rasterised on a coarse output grid (every
``out_step`` px), each sample taking the barycentric mix of its triangle's *rest*
positions: that is the exact inverse of the piecewise-linear ``f``. The coarse backward
map is upsampled (bilinear) to every pixel, then the frame and its mask are resampled.
Where triangles overlap after a fold, the last one drawn wins.

Coordinates here are OpenCV's: pixel ``(i, j)`` has its centre at ``x = j, y = i``
(a scene's canvas point is this plus 0.5).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from puppet.deform.skeleton import skeleton_from_distances, skeleton_solve
from puppet.geom.geodesic import grid_graph
from puppet.imaging.inpaint import inpaint

__all__ = ["grid_mesh", "backward_map", "skeleton_maps", "WarpMaps", "composite", "background_fill"]

#: Backward-map value of output samples no triangle covers (far outside every frame).
FAR = -1e6


def grid_mesh(mask: np.ndarray, step: int, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A triangulated grid over the cells that hold mask pixels and one cell around them
    (the margin keeps the silhouette inside the triangles), joints as vertices.

    Parameters
    ----------
    mask : (H, W) bool. step : grid spacing, px.
    joints : (k, 2) float, OpenCV pixel coordinates.

    Returns
    -------
    V : (n, 2) float vertices (grid points; the vertex nearest each joint moved onto it).
    F : (m, 3) int triangles, two per occupied cell.
    b : (k,) int vertex of each joint.
    """
    import cv2

    H, W = mask.shape
    gw, gh = -(-W // step), -(-H // step)  # cells
    pad = np.zeros((gh * step, gw * step), np.uint8)
    pad[:H, :W] = mask
    cells = pad.reshape(gh, step, gw, step).max(axis=(1, 3))
    J = np.asarray(joints, dtype=np.float64).reshape(-1, 2)
    ci = np.clip((J[:, 1] // step).astype(int), 0, gh - 1)
    cj = np.clip((J[:, 0] // step).astype(int), 0, gw - 1)
    cells[ci, cj] = 1  # a joint off the mask still gets its cell
    cells = cv2.dilate(cells, np.ones((3, 3), np.uint8)).astype(bool)  # one cell of margin
    vid = -np.ones((gh + 1, gw + 1), np.int64)
    used = np.zeros((gh + 1, gw + 1), bool)
    used[:-1, :-1] |= cells
    used[1:, :-1] |= cells
    used[:-1, 1:] |= cells
    used[1:, 1:] |= cells
    vid[used] = np.arange(used.sum())
    yy, xx = np.nonzero(used)
    V = np.c_[xx * float(step), yy * float(step)]
    r, c = np.nonzero(cells)
    a, bb, cc, d = vid[r, c], vid[r, c + 1], vid[r + 1, c], vid[r + 1, c + 1]
    F = np.r_[np.c_[a, bb, d], np.c_[a, d, cc]]
    b = np.empty(len(J), np.int64)
    taken: set[int] = set()
    for k, (x, y) in enumerate(J):
        i0, j0 = int(np.clip(round(y / step), 0, gh)), int(np.clip(round(x / step), 0, gw))
        cand = [(abs(i - y / step) + abs(j - x / step), vid[i, j])
                for i in range(max(i0 - 1, 0), min(i0 + 2, gh + 1))
                for j in range(max(j0 - 1, 0), min(j0 + 2, gw + 1)) if vid[i, j] >= 0]
        free = [v for _, v in sorted(cand) if v not in taken]
        if not free:
            raise ValueError(f"joints {k} and another are closer than the grid step ({step} px)")
        b[k] = free[0]
        taken.add(int(free[0]))
        V[b[k]] = (x, y)
    return V, F, b


def _u8(mask: np.ndarray) -> np.ndarray:
    """A bool mask as uint8 0/1 (a view when it can be)."""
    return mask.view(np.uint8) if mask.dtype == bool and mask.flags.c_contiguous else mask.astype(np.uint8)


def _cell_fraction(mask: np.ndarray, step: int) -> np.ndarray:
    """(gh, gw) fraction of each grid cell's pixels on the mask."""
    import cv2

    H, W = mask.shape
    gw, gh = -(-W // step), -(-H // step)
    out = np.zeros((gh, gw), np.float32)
    x, y, w, h = cv2.boundingRect(_u8(mask))
    if w == 0:
        return out
    c0, r0 = x // step, y // step  # only the cells over the mask's bounding box
    c1, r1 = -(-(x + w) // step), -(-(y + h) // step)
    pad = np.zeros(((r1 - r0) * step, (c1 - c0) * step), np.uint8)
    sub = mask[r0 * step:r1 * step, c0 * step:c1 * step]
    pad[:sub.shape[0], :sub.shape[1]] = sub
    out[r0:r1, c0:c1] = pad.reshape(r1 - r0, step, c1 - c0, step).sum(axis=(1, 3), dtype=np.int32) / (step * step)
    return out


def interior_distances(mask: np.ndarray, sources: np.ndarray, targets: np.ndarray, *, res: int = 3) -> np.ndarray:
    """Shortest paths inside the mask from each source point to each target point.

    The mask is reduced to cells of ``res`` px (a cell is inside when at least half
    of its pixels are); Dijkstra runs over the 8-connected inside cells. A point off the
    mask is joined to its nearest inside cell by a straight line.

    Parameters
    ----------
    mask : (H, W) bool. sources : (k, 2), targets : (n, 2) float, OpenCV pixel coordinates.

    Returns
    -------
    D : (k, n) float64, finite (a target no source reaches inside the mask gets the
        Euclidean distance).
    """
    import cv2
    from scipy.sparse.csgraph import dijkstra

    S = np.asarray(sources, np.float64).reshape(-1, 2)
    T = np.asarray(targets, np.float64).reshape(-1, 2)
    on = _cell_fraction(mask, res) >= 0.5
    gh, gw = on.shape

    def cell(P):
        return (np.clip(((P[:, 1] + 0.5) // res).astype(np.int64), 0, gh - 1),
                np.clip(((P[:, 0] + 0.5) // res).astype(np.int64), 0, gw - 1))
    si, sj = cell(S)
    ti, tj = cell(T)
    on[si, sj] = True  # every source has its cell
    oi, oj = np.nonzero(on)
    r0, c0 = min(oi.min(), ti.min(initial=gh)), min(oj.min(), tj.min(initial=gw))
    r1, c1 = max(oi.max(), ti.max(initial=0)) + 1, max(oj.max(), tj.max(initial=0)) + 1
    on = on[r0:r1, c0:c1]  # the work is on the character's bounding box only
    si, sj, ti, tj = si - r0, sj - c0, ti - r0, tj - c0
    idx, G = grid_graph(on, res)
    Dn = dijkstra(G, directed=False, indices=idx[si, sj])
    # each target's nearest inside cell (labels of the nearest zero pixel, in raster order)
    _, labels = cv2.distanceTransformWithLabels((~on).astype(np.uint8), cv2.DIST_L2, 3,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    node = labels[ti, tj].astype(np.int64) - 1
    ni, nj = np.divmod(np.flatnonzero(on)[node], gw)
    centre = np.c_[(nj + c0 + 0.5) * res - 0.5, (ni + r0 + 0.5) * res - 0.5]
    D = Dn[:, node] + np.linalg.norm(T - centre, axis=1)[None, :]
    lost = ~np.isfinite(D)
    if lost.any():
        si_, ti_ = np.nonzero(lost)
        D[lost] = np.linalg.norm(S[si_] - T[ti_], axis=1)
    return D


def _grid_samples(W: int, H: int, out_step: int) -> tuple[int, int]:
    return -(-W // out_step), -(-H // out_step)


def backward_map(U: np.ndarray, V: np.ndarray, F: np.ndarray, size: tuple[int, int], out_step: int,
                 *, max_samples: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    """Rasterise the deformed triangles ``U[F]`` on the coarse output grid.

    Sample ``(i, j)`` sits at pixel ``((j + .5) s - .5, (i + .5) s - .5)`` with ``s =
    out_step`` (so that ``cv2.resize`` by ``s`` puts it back exactly).

    Returns
    -------
    src : (gh, gw, 2) float32 rest position read by each sample (:data:`FAR` where none).
    covered : (gh, gw) bool.
    """
    W, H = size
    gw, gh = _grid_samples(W, H, out_step)
    P = (U[F] + 0.5) / out_step - 0.5  # (m, 3, 2) in sample units
    lo = np.ceil(P.min(axis=1)).astype(np.int64)
    hi = np.floor(P.max(axis=1)).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [gw - 1, gh - 1])
    nx, ny = hi[:, 0] - lo[:, 0] + 1, hi[:, 1] - lo[:, 1] + 1
    cnt = np.where((nx > 0) & (ny > 0), nx * ny, 0)
    cnt[cnt > max_samples] = 0  # a triangle torn across the picture: not drawn
    tri = np.repeat(np.arange(len(F)), cnt)
    local = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    sx = lo[tri, 0] + local % nx[tri]
    sy = lo[tri, 1] + local // nx[tri]
    A, B, C = P[tri, 0], P[tri, 1], P[tri, 2]
    e0, e1 = B - A, C - A
    px, py = sx - A[:, 0], sy - A[:, 1]
    den = e0[:, 0] * e1[:, 1] - e1[:, 0] * e0[:, 1]
    ok = np.abs(den) > 1e-12
    den = np.where(ok, den, 1.0)
    l1 = (px * e1[:, 1] - e1[:, 0] * py) / den
    l2 = (e0[:, 0] * py - px * e0[:, 1]) / den
    l0 = 1.0 - l1 - l2
    eps = 1e-9
    inside = ok & (l0 >= -eps) & (l1 >= -eps) & (l2 >= -eps)
    t = F[tri[inside]]
    src_pts = (l0[inside, None] * V[t[:, 0]] + l1[inside, None] * V[t[:, 1]] + l2[inside, None] * V[t[:, 2]])
    src = np.full((gh, gw, 2), FAR, np.float32)
    covered = np.zeros((gh, gw), bool)
    src[sy[inside], sx[inside]] = src_pts
    covered[sy[inside], sx[inside]] = True
    return src, covered


def _extend(src: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """Give the samples around the covered ones the mean of their covered neighbours, so
    that bilinear upsampling never mixes a real position with :data:`FAR` next to the
    character (a ring of one sample; beyond it the map stays far away)."""
    import cv2

    cov = covered.astype(np.float32)
    n = cv2.boxFilter(cov, -1, (3, 3), normalize=False, borderType=cv2.BORDER_CONSTANT)
    ring = (~covered) & (n > 0)
    out = src.copy()
    for c in range(2):
        s = cv2.boxFilter(np.where(covered, src[..., c], 0).astype(np.float32), -1, (3, 3), normalize=False,
                          borderType=cv2.BORDER_CONSTANT)
        out[..., c][ring] = s[ring] / n[ring]
    return out


@dataclass
class WarpMaps:
    """Full-resolution backward maps for ``cv2.remap`` and what they came from.

    Attributes
    ----------
    mapx, mapy : (H, W) float32 (:data:`FAR` outside ``roi``). V, U : (n, 2) rest and
    deformed grid vertices. F : (m, 3) triangles drawn. b : (k,) joint vertices.
    roi : (x0, y0, x1, y1) the pixels the warped character may reach.
    """

    mapx: np.ndarray
    mapy: np.ndarray
    V: np.ndarray
    U: np.ndarray
    F: np.ndarray
    b: np.ndarray
    roi: tuple[int, int, int, int] = (0, 0, 0, 0)


def skeleton_maps(mask: np.ndarray, joints, targets, bones, *, step: int = 6, out_step: int = 4,
                  k: float = 1.2, tear: float = 3.0) -> WarpMaps:
    """Backward maps re-posing the character from ``joints`` to ``targets``.

    Parameters
    ----------
    mask : (H, W) bool, the character on this frame.
    joints, targets : (k, 2) float, OpenCV pixel coordinates.
    bones : (m, 2) int pin index pairs.
    step : grid spacing of the MLS evaluation, px. out_step : spacing of the rasterised
        backward map, px. k : skeleton range factor (paper: 1.2).
    tear : a triangle whose edge grows more than this factor is left out (it straddled a gap).

    Interior distances are measured on the mask itself (:func:`interior_distances`, at
    ``step / 2``), not along the grid, so two limbs that share a grid cell stay apart.
    """
    import cv2

    H, W = mask.shape
    V, F, b = grid_mesh(mask, step, joints)
    D = interior_distances(mask, V[b], V, res=max(1, step // 2))
    D[np.arange(len(b)), b] = 0.0
    data = skeleton_from_distances(V, b, bones, D, k=k)
    U = skeleton_solve(data, np.asarray(targets, np.float64).reshape(-1, 2))
    # a triangle torn apart (it straddled two limbs that now part) is not drawn
    e = np.stack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1)
    rest = np.linalg.norm(V[e[..., 0]] - V[e[..., 1]], axis=-1)
    now = np.linalg.norm(U[e[..., 0]] - U[e[..., 1]], axis=-1)
    F = F[(now <= tear * rest + 1e-9).all(axis=1)]
    # where the warp folds, the cells fullest of character are drawn last (they win)
    frac = _cell_fraction(mask, step)
    cell = (V[F].mean(axis=1) // step).astype(np.int64)
    F = F[np.argsort(frac[cell[:, 1], cell[:, 0]], kind="stable")]
    src, covered = backward_map(U, V, F, (W, H), out_step)
    src = _extend(src, covered)
    mapx = np.full((H, W), FAR, np.float32)
    mapy = np.full((H, W), FAR, np.float32)
    roi = (0, 0, 0, 0)
    if covered.any():  # only the samples around the character are upsampled
        gh, gw = covered.shape
        rows, cols = np.nonzero(covered)
        r0, r1 = max(rows.min() - 2, 0), min(rows.max() + 3, gh)
        c0, c1 = max(cols.min() - 2, 0), min(cols.max() + 3, gw)
        block = cv2.resize(src[r0:r1, c0:c1], ((c1 - c0) * out_step, (r1 - r0) * out_step),
                           interpolation=cv2.INTER_LINEAR)
        x0, y0 = c0 * out_step, r0 * out_step
        x1, y1 = min(c1 * out_step, W), min(r1 * out_step, H)
        mapx[y0:y1, x0:x1] = block[:y1 - y0, :x1 - x0, 0]
        mapy[y0:y1, x0:x1] = block[:y1 - y0, :x1 - x0, 1]
        roi = (x0, y0, x1, y1)
    return WarpMaps(mapx=mapx, mapy=mapy, V=V, U=U, F=F, b=b, roi=roi)


def background_fill(rgb: np.ndarray, mask: np.ndarray, method: str = "telea", *, grow: int = 3,
                    scale: int = 4) -> np.ndarray:
    """The frame with the character's pixels (``mask`` grown by ``grow`` px) refilled from
    the background around them; untouched elsewhere. The fill is computed on the hole's
    bounding box at 1/``scale`` resolution (a smooth fill does not need more).

    Parameters
    ----------
    rgb : (H, W, 3) uint8. mask : (H, W) bool. method : ``telea``, ``ns``, ``pyramid``, ``fsr``.
    """
    import cv2

    out = rgb.copy()
    H, W = mask.shape
    box = cv2.boundingRect(_u8(mask))
    if box[2] == 0:
        return out
    m = 4 * grow + 2 * scale
    x0, y0 = max(box[0] - m, 0), max(box[1] - m, 0)
    x1, y1 = min(box[0] + box[2] + m, W), min(box[1] + box[3] + m, H)
    rh = cv2.dilate(mask[y0:y1, x0:x1].astype(np.uint8), np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)) > 0
    roi = rgb[y0:y1, x0:x1]
    if scale > 1:
        sw, sh = max(1, (x1 - x0) // scale), max(1, (y1 - y0) // scale)
        small = cv2.resize(roi, (sw, sh), interpolation=cv2.INTER_AREA)
        sh_hole = cv2.resize(rh.astype(np.uint8), (sw, sh), interpolation=cv2.INTER_NEAREST) > 0
        sh_hole |= cv2.resize(rh.astype(np.float32), (sw, sh), interpolation=cv2.INTER_AREA) > 0
        if sh_hole.all():
            return out
        filled = inpaint(small, sh_hole, method if method != "none" else "telea", radius=2.0)
        filled = cv2.resize(filled, (x1 - x0, y1 - y0), interpolation=cv2.INTER_LINEAR)
    else:
        if rh.all():
            return out
        filled = inpaint(np.ascontiguousarray(roi), rh, method if method != "none" else "telea")
    sub = out[y0:y1, x0:x1]
    sub[rh] = filled[rh]
    return out


def composite(rgb: np.ndarray, background: np.ndarray, mask: np.ndarray, maps: WarpMaps) -> np.ndarray:
    """The re-posed frame: the character (``rgb`` where ``mask``) resampled through ``maps``
    over ``background``; pixels the warped character does not reach are ``background``'s.

    Returns (H, W, 3) uint8.
    """
    import cv2

    out = background.copy()
    x0, y0, x1, y1 = maps.roi
    if x1 <= x0 or y1 <= y0:
        return out
    mx, my = maps.mapx[y0:y1, x0:x1], maps.mapy[y0:y1, x0:x1]
    fg = cv2.remap(rgb, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    bx, by, bw, bh = cv2.boundingRect(_u8(mask))  # the mask is read on its bounding box only
    bx, by = max(bx - 1, 0), max(by - 1, 0)
    sub_mask = mask[by:by + bh + 2, bx:bx + bw + 2].astype(np.float32)
    alpha = cv2.remap(sub_mask, mx - np.float32(bx), my - np.float32(by), cv2.INTER_LINEAR,
                      borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
    sub = out[y0:y1, x0:x1]
    np.clip(alpha, 0.0, 1.0, out=alpha)
    sub[:] = cv2.blendLinear(fg, np.ascontiguousarray(sub), alpha, 1.0 - alpha)  # rounds and saturates
    return out
