"""Helpers shared by the example-scene generators in this folder."""
from __future__ import annotations

import json

import cv2
import numpy as np


def disk(r):
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


def erode(m, r):
    return cv2.erode(m.astype(np.uint8), disk(r)).astype(bool)


def samples(p, q, step=0.25):
    n = max(2, int(np.ceil(np.linalg.norm(np.subtract(q, p)) / step)) + 1)
    t = np.linspace(0, 1, n)[:, None]
    return np.asarray(p, float) + t * (np.asarray(q, float) - np.asarray(p, float))


def on_mask(m, P):
    j, i = np.floor(P[:, 0]).astype(int), np.floor(P[:, 1]).astype(int)
    H, W = m.shape
    ok = (i >= 0) & (i < H) & (j >= 0) & (j < W)
    return bool(ok.all() and m[i[ok], j[ok]].all())


def dump(scene):
    """JSON that keeps short values on one line (a layer, a pin, a segment, a pose) and
    packs long lists of points several to a line."""
    width = 110

    def fmt(v, ind):
        flat = json.dumps(v)
        if len(flat) + ind <= width or not isinstance(v, (dict, list)):
            return flat
        pad = " " * (ind + 1)
        if isinstance(v, dict):
            body = [f"{pad}{json.dumps(k)}: {fmt(x, ind + 1)}" for k, x in v.items()]
            return "{\n" + ",\n".join(body) + "\n" + " " * ind + "}"
        items = [fmt(x, ind + 1) for x in v]
        if all("\n" not in s and len(s) <= 24 for s in items):  # points, numbers: pack them
            lines, cur = [], ""
            for s in items:
                if cur and len(pad) + len(cur) + len(s) + 2 > width:
                    lines.append(cur)
                    cur = ""
                cur = f"{cur}, {s}" if cur else s
            lines.append(cur)
            return "[\n" + ",\n".join(pad + s for s in lines) + "\n" + " " * ind + "]"
        return "[\n" + ",\n".join(pad + s for s in items) + "\n" + " " * ind + "]"
    return fmt(scene, 0) + "\n"


def draw_links_and_pins(draw, scene, *, link=(0, 0, 0, 255), pin=(255, 255, 0, 255), width=1):
    """Overlay a scene's link segments and pin circles on a PIL ImageDraw (previews)."""
    for L in scene["links"]:
        for p, q in L["segments"]:
            draw.line([tuple(p), tuple(q)], fill=link, width=width)
    for p in scene["pins"]:
        x, y = p["at"]
        draw.ellipse([x - 3, y - 3, x + 3, y + 3], outline=pin)
