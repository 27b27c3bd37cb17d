"""CPU reference compositor for the GL compositor's tests (numpy only, no GL).

Same conventions as OpenGL: output pixel (x, y) samples the canvas at its centre
((x + 0.5) * cw / W, (y + 0.5) * ch / H); textures are premultiplied (rounded to uint8)
and sampled bilinearly with texel centres at (i + 0.5) / w and clamp to edge. Every
triangle of every layer that contains a pixel centre gives a fragment (barycentric
texture coordinate and depth); fragments with alpha below 0.5/255 are dropped. A fragment
with alpha >= 254.5/255 is opaque: it hides everything behind it. The rest are sorted
front first and composited front to back, then over the background.

Order (the tie rule of puppet.render.compositor): higher depth first; at equal depth the
later layer in the list; in one layer at equal depth opaque fragments before translucent
ones, then the later triangle first. Slow (Python loop over triangles): for small test
scenes only.
"""
from __future__ import annotations

import numpy as np

ALPHA_MIN = 0.5 / 255.0
ALPHA_OPAQUE = 254.5 / 255.0
# Pixel centres are nudged by this irrational-ish offset so that a centre lying exactly
# on an edge shared by two triangles is counted in only one of them.
_NUDGE = np.array([1.234567e-5, 2.345678e-5])


def premultiplied(image: np.ndarray) -> np.ndarray:
    """Straight uint8 RGBA -> premultiplied float in 0..1, rounded to uint8 steps first."""
    img = image.astype(np.float64)
    out = img.copy()
    out[..., :3] = np.floor(img[..., :3] * img[..., 3:] / 255.0 + 0.5)
    return out / 255.0


def bilinear(texture: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Sample texture (h, w, c) at uv (k, 2) in 0..1 like GL LINEAR + CLAMP_TO_EDGE."""
    h, w = texture.shape[:2]
    s = uv[:, 0] * w - 0.5
    t = uv[:, 1] * h - 0.5
    i0, j0 = np.floor(s).astype(int), np.floor(t).astype(int)
    fs, ft = (s - i0)[:, None], (t - j0)[:, None]
    i0c, i1c = np.clip(i0, 0, w - 1), np.clip(i0 + 1, 0, w - 1)
    j0c, j1c = np.clip(j0, 0, h - 1), np.clip(j0 + 1, 0, h - 1)
    top = texture[j0c, i0c] * (1 - fs) + texture[j0c, i1c] * fs
    bottom = texture[j1c, i0c] * (1 - fs) + texture[j1c, i1c] * fs
    return top * (1 - ft) + bottom * ft


def _fragments(layer, centres: np.ndarray):
    """(pixel index, depth, triangle index, premultiplied rgba) of every fragment."""
    tex = premultiplied(layer.image)
    h, w = layer.image.shape[:2]
    uv_all = (np.asarray(layer.rest, float) - np.asarray(layer.offset, float)) / (w, h)
    pos = np.asarray(layer.deformed, float)
    depth = np.asarray(layer.depth, float)
    pix, dep, tid, col = [], [], [], []
    for t, tri in enumerate(np.asarray(layer.triangles)):
        a, b, c = pos[tri]
        lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        sel = np.nonzero(np.all((centres >= lo - 1) & (centres <= hi + 1), axis=1))[0]
        if sel.size == 0:
            continue
        p = centres[sel]
        det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        if det == 0:
            continue
        l1 = ((p[:, 0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (p[:, 1] - a[1])) / det
        l2 = ((b[0] - a[0]) * (p[:, 1] - a[1]) - (p[:, 0] - a[0]) * (b[1] - a[1])) / det
        bary = np.stack([1 - l1 - l2, l1, l2], axis=1)
        inside = np.all(bary >= 0, axis=1)
        if not inside.any():
            continue
        bary = bary[inside]
        rgba = bilinear(tex, bary @ uv_all[tri])
        keep = rgba[:, 3] >= ALPHA_MIN
        pix.append(sel[inside][keep])
        d0, d1, d2 = depth[tri]  # plane form: exactly d0 when the corners agree (ties)
        dep.append((d0 + bary[:, 1] * (d1 - d0) + bary[:, 2] * (d2 - d0))[keep])
        tid.append(np.full(int(keep.sum()), t))
        col.append(rgba[keep])
    if not pix:
        return np.zeros(0, int), np.zeros(0), np.zeros(0, int), np.zeros((0, 4))
    return np.concatenate(pix), np.concatenate(dep), np.concatenate(tid), np.concatenate(col)


def reference_composite(layers, canvas, *, size=None, background=(0, 0, 0, 0),
                        return_float: bool = False) -> np.ndarray:
    """Composite layers (objects with the DrawLayer fields) on the CPU.

    Returns
    -------
    ndarray, shape (H, W, 4)
        Straight-alpha RGBA uint8 (row 0 = top), or premultiplied float when
        ``return_float``.
    """
    cw, ch = canvas
    W, H = size or canvas
    ys, xs = np.mgrid[0:H, 0:W]
    centres = np.stack([(xs.ravel() + 0.5) * cw / W, (ys.ravel() + 0.5) * ch / H], axis=1)
    centres = centres + _NUDGE
    parts = [_fragments(layer, centres) for layer in layers]
    parts = parts or [(np.zeros(0, int), np.zeros(0), np.zeros(0, int), np.zeros((0, 4)))]
    pix = np.concatenate([p[0] for p in parts])
    dep = np.concatenate([p[1] for p in parts])
    tid = np.concatenate([p[2] for p in parts])
    col = np.concatenate([p[3] for p in parts])
    lay = np.concatenate([np.full(len(p[0]), i) for i, p in enumerate(parts)])
    opaque = col[:, 3] >= ALPHA_OPAQUE
    # by pixel, then front first: depth, layer, opaque, triangle (all descending)
    order = np.lexsort((-tid, -opaque.astype(int), -lay, -dep, pix))
    pix, col, opaque = pix[order], col[order], opaque[order]
    start = np.r_[0, np.nonzero(np.diff(pix))[0] + 1] if pix.size else np.zeros(0, int)
    group = np.repeat(start, np.diff(np.r_[start, pix.size]))
    rank = np.arange(pix.size) - group
    # drop what lies behind the nearest opaque fragment; that one counts as alpha 1
    ahead = np.cumsum(opaque) - opaque
    hidden = (ahead - (ahead[group] if pix.size else 0)) > 0
    pix, col, rank = pix[~hidden], col[~hidden], rank[~hidden]
    col[opaque[~hidden], 3] = 1.0
    accum = np.zeros((W * H, 4))
    for r in range(int(rank.max()) + 1 if rank.size else 0):
        sel = rank == r
        p = pix[sel]
        accum[p] += (1 - accum[p, 3:4]) * col[sel]
    if isinstance(background, np.ndarray) and background.ndim == 3:
        bg = bilinear(premultiplied(background), centres / (cw, ch))
    else:
        colour = np.asarray(background, np.uint8).reshape(1, 1, 4)
        bg = np.broadcast_to(premultiplied(colour)[0, 0], accum.shape)
    accum = accum + (1 - accum[:, 3:4]) * bg
    accum = accum.reshape(H, W, 4)
    if return_float:
        return accum
    alpha = accum[..., 3:4]
    rgb = np.where(alpha > 0, accum[..., :3] / np.where(alpha > 0, alpha, 1), 0)
    out = np.concatenate([np.clip(rgb, 0, 1), np.clip(alpha, 0, 1)], axis=-1)
    return np.rint(out * 255).astype(np.uint8)
