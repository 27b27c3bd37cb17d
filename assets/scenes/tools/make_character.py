"""Generate ``assets/scenes/character.json`` from Kenney's cut-out character parts.

Run from anywhere::

    .venv/bin/python assets/scenes/tools/make_character.py [--preview OUT.png]

What it does:

1. Writes left-side copies of the one-sided parts (arm, sleeve, hand, leg, trouser leg,
   shoe) mirrored with Pillow to ``assets/kenney-character/mirrored/``.
2. Places every part at its native pixel size with an ``offset`` on a 700 x 720 canvas
   (right-side parts by hand, left-side parts mirrored about the canvas centre line);
   the arm is fitted under its sleeve and the leg inside its trouser leg by searching
   the offset that leaves the fewest limb pixels outside the garment.
3. Computes each link's segments inside the overlap of both layers' masks (alpha > 0 at
   their offsets): the overlap is eroded by 2 px, joints get one segment along the
   overlap's principal axis (shrunk by 3 px at each end), garment links get a chain of
   segments through the centroids of slices along the principal axis. Regions already
   used by a link segment of the same layer are kept out, so no two segments of one
   layer cross or touch. Every segment is verified point by point (every 0.25 px) on
   the eroded overlap before it is written.
4. Picks pins inside the masks away from all link segments and writes the scene JSON
   with poses and an animation.

``--preview OUT.png`` also writes a flat Pillow composite of the rest layout, with the
link segments drawn in, for checking the assembly without puppet.
"""
from __future__ import annotations

import argparse
import os

import cv2
import numpy as np
from PIL import Image, ImageDraw

from common import draw_links_and_pins, dump, erode, on_mask, samples  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.dirname(HERE)
ASSETS = os.path.dirname(SCENES)
KEN = os.path.join(ASSETS, "kenney-character")
MIR = os.path.join(KEN, "mirrored")
OUT = os.path.join(SCENES, "character.json")

CANVAS = (700, 720)
CX = CANVAS[0] // 2  # the figure's vertical centre line; left parts mirror right parts about it
BACKGROUND = [84, 150, 200, 255]

# Triangle size (px²). puppet's default (~2000 triangles a layer, here 6 px² for most
# parts, 37 000 triangles in the one linked group) is slow to solve and its ARAP result
# keeps a few folded triangles next to dragged pins, which the fold relaxation then
# sometimes "repairs" into a rest pose with only the pins moved (see the report);
# 30 px² solves in ~0.05 s a pose with no folds over the whole animation.
MESH_AREA = {"*": 30.0, "face": 10.0}
MASKS = os.path.join(KEN, "masks")
PINCHED = ["brown2Man5"]  # parts whose plain alpha mask crashes puppet's mesher (pinched holes)
MIRRORED = ["tint1_arm", "redArm_long", "tint1_hand", "tint1_leg", "pantsLightBlue_long", "brownShoe5"]


def write_mirrored():
    os.makedirs(MIR, exist_ok=True)
    for name in MIRRORED:
        im = Image.open(os.path.join(KEN, name + ".png")).convert("RGBA")
        im.transpose(Image.Transpose.FLIP_LEFT_RIGHT).save(os.path.join(MIR, name + ".png"), optimize=True)


def open_pinches(alpha):
    """A mask (alpha > 0 minus a few faint pixels) whose outline has no pinched holes.

    puppet meshes the mask grown by one pixel; where two faint anti-aliased pixels meet
    diagonally across a narrow notch (between the hair's spikes), the grown mask encloses
    a one-pixel hole whose contour touches the outer contour, and Triangle crashes on it
    (see the report). Dropping the faint pixels around each such hole opens the notch.
    """
    from puppet.geom.contour import mask_regions

    m = alpha > 0
    yy, xx = np.mgrid[0:m.shape[0], 0:m.shape[1]]
    for _ in range(20):
        holes = [h for r in mask_regions(m) for h in r.holes]
        if not holes:
            return m
        for h in holes:
            c = h.mean(0) - 0.5  # pixel (i, j) has its centre at (j + 0.5, i + 0.5)
            for rad in (2, 3, 4, 5):
                near = (xx - c[0]) ** 2 + (yy - c[1]) ** 2 <= rad * rad
                drop = near & m & (alpha < 128)
                if drop.any():
                    m &= ~drop
                    break
    raise RuntimeError("could not open the pinched holes")


def write_masks():
    """Mask files for the parts whose alpha outline has pinched holes."""
    os.makedirs(MASKS, exist_ok=True)
    out = {}
    for name in PINCHED:
        a = np.array(Image.open(os.path.join(KEN, name + ".png")).convert("RGBA"))[..., 3]
        m = open_pinches(a)
        Image.fromarray(np.where(m, 255, 0).astype(np.uint8), "L").save(os.path.join(MASKS, name + ".png"),
                                                                       optimize=True)
        out[name] = f"../kenney-character/masks/{name}.png"
        print(f"{name}: {int((a > 0).sum() - m.sum())} faint pixels left out of the mask")
    return out


def rgba(rel):
    return np.array(Image.open(os.path.join(SCENES, rel)).convert("RGBA"))


def part(name, side="r"):
    """Scene-relative path of a part image; side 'l' = the mirrored copy of a one-sided part."""
    if side == "l" and name in MIRRORED:
        return f"../kenney-character/mirrored/{name}.png"
    return f"../kenney-character/{name}.png"


def fit_inside(inner, outer, outer_off, search=range(-25, 26), rows=None):
    """Offset of ``inner`` that leaves the fewest of its alpha pixels outside ``outer``.

    ``rows`` limits the count to the inner image's rows in that slice (e.g. not the
    bottom end that must stick out)."""
    a = inner[..., 3] > 0
    if rows is not None:
        a = a.copy()
        keep = np.zeros(a.shape[0], bool)
        keep[rows] = True
        a[~keep] = False
    b = outer[..., 3] > 0
    best = None
    H, W = b.shape
    for dy in search:
        for dx in search:
            ys, xs = np.nonzero(a)
            X, Y = xs + dx, ys + dy
            ok = (X >= 0) & (X < W) & (Y >= 0) & (Y < H)
            inside = np.zeros(len(X), bool)
            inside[ok] = b[Y[ok], X[ok]]
            score = (~inside).sum()
            if best is None or score < best[0] or (score == best[0] and abs(dx) + abs(dy) < best[1]):
                best = (score, abs(dx) + abs(dy), dx, dy)
    return [outer_off[0] + best[2], outer_off[1] + best[3]]


def layout():
    """[(name, image, offset)] back to front."""
    R = {}  # right-side and centre parts: name -> (image, offset)
    R["shirt"] = (part("redShirt1"), [274, 250])
    R["neck"] = (part("tint1_neck"), [302, 246])
    R["head"] = (part("tint1_head"), [264, 86])
    R["face"] = (part("face1"), [301, 133])
    R["hair"] = (part("brown2Man5"), [273, 48])
    R["sleeve_r"] = (part("redArm_long"), [392, 256])
    R["waist"] = (part("pantsLightBlue3"), [274, 402])
    R["trouser_r"] = (part("pantsLightBlue_long"), [350, 422])
    # the bare arm under its sleeve, the leg inside its trouser leg
    R["arm_r"] = (part("tint1_arm"), fit_inside(rgba(part("tint1_arm")), rgba(part("redArm_long")),
                                                R["sleeve_r"][1]))
    leg = rgba(part("tint1_leg"))
    R["leg_r"] = (part("tint1_leg"), fit_inside(leg, rgba(part("pantsLightBlue_long")), R["trouser_r"][1],
                                                rows=slice(0, leg.shape[0] - 20)))
    ax, ay = R["arm_r"][1]
    R["hand_r"] = (part("tint1_hand"), [ax + 128, ay + 104])
    lx, ly = R["leg_r"][1]
    R["shoe_r"] = (part("brownShoe5"), [lx + 30, ly + 150])

    def mirror(name):
        img, (x, y) = R[name + "_r"]
        w = rgba(img).shape[1]
        return (part(os.path.basename(img)[:-4], "l"), [CANVAS[0] - x - w, y])

    for n in ("arm", "sleeve", "hand", "leg", "trouser", "shoe"):
        R[n + "_l"] = mirror(n)
    order = ["leg_l", "leg_r", "shoe_l", "shoe_r", "trouser_l", "trouser_r",
             "arm_l", "arm_r", "hand_l", "hand_r", "neck", "shirt", "waist",
             "sleeve_l", "sleeve_r", "head", "face", "hair"]
    return [(n, R[n][0], R[n][1]) for n in order]


# ---- masks and segments ------------------------------------------------------------
def canvas_mask(img, off, mask_files={}):
    a = rgba(img)[..., 3] > 0
    name = os.path.basename(img)[:-4]
    if name in mask_files:
        a &= np.array(Image.open(os.path.join(SCENES, mask_files[name]))) > 0
    m = np.zeros((CANVAS[1], CANVAS[0]), bool)
    h, w = a.shape
    m[off[1]:off[1] + h, off[0]:off[0] + w] = a
    return m










def largest_component(m):
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m.astype(np.uint8), connectivity=8)
    if n <= 1:
        return m
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return lab == k


def principal(m):
    ys, xs = np.nonzero(m)
    P = np.stack([xs + 0.5, ys + 0.5], 1)
    c = P.mean(0)
    w, V = np.linalg.eigh(np.cov((P - c).T))
    return P, c, V[:, 1]  # largest eigenvector


def clip_line(m, c, d, shrink):
    """The longest piece of the line c + t d through c that stays on m, shrunk at both ends."""
    def reach(sign):
        t = 0.0
        while on_mask(m, (c + sign * (t + 0.25) * d)[None]):
            t += 0.25
        return t
    t0, t1 = reach(-1), reach(+1)
    a, b = c - (t0 - shrink) * d, c + (t1 - shrink) * d
    return a, b


def joint_segment(ov, shrink=3.0):
    P, c, d = principal(ov)
    if not on_mask(ov, c[None]):  # a bent overlap: start from its pixel nearest the centroid
        c = P[np.argmin(np.linalg.norm(P - c, axis=1))]
    a, b = clip_line(ov, c, d, shrink)
    return [(a, b)]


def chain_segments(ov, n, gap=2.5):
    """Segments through the centroids of n slices across the overlap's principal axis."""
    P, c, d = principal(ov)
    t = (P - c) @ d
    edges = np.linspace(t.min(), t.max(), n + 1)  # n slices
    cents = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (t >= lo) & (t < hi)
        q = P[sel].mean(0)
        if not on_mask(ov, q[None]):
            q = P[sel][np.argmin(np.linalg.norm(P[sel] - q, axis=1))]
        cents.append(q)
    segs = []
    for p, q in zip(cents[:-1], cents[1:]):
        u = (q - p) / np.linalg.norm(q - p)
        a, b = p + gap * u, q - gap * u
        if on_mask(ov, samples(a, b)):
            segs.append((a, b))
    return segs


def make_links(layers, masks, spec, clearance=6):
    used = {n: np.zeros_like(m) for n, m in masks.items()}
    links = []
    for a, b, kind, n, margin in spec:
        ov = masks[a] & masks[b] & ~used[a] & ~used[b]
        ov = erode(ov, margin)
        if kind == "each":  # a part made of separate pieces (the face): one joint per piece
            k, lab, st, _ = cv2.connectedComponentsWithStats(ov.astype(np.uint8), connectivity=8)
            segs = [s for c in range(1, k) if st[c, cv2.CC_STAT_AREA] > 10 for s in joint_segment(lab == c)]
        else:
            ov = largest_component(ov)
            assert ov.sum() > 10, (a, b, "no overlap")
            segs = joint_segment(ov) if kind == "joint" else chain_segments(ov, n)
        out = []
        for p, q in segs:
            p, q = np.round(p, 1), np.round(q, 1)
            S = samples(p, q)
            assert on_mask(ov if kind != "each" else erode(masks[a] & masks[b], margin), S), (a, b, p, q)
            assert on_mask(masks[a], S) and on_mask(masks[b], S)
            assert np.linalg.norm(q - p) >= 3, (a, b, "segment too short")
            out.append([[float(p[0]), float(p[1])], [float(q[0]), float(q[1])]])
            band = np.zeros(ov.shape, np.uint8)
            cv2.line(band, tuple(int(round(v)) for v in p), tuple(int(round(v)) for v in q), 1,
                     thickness=2 * clearance + 1)
            used[a] |= band.astype(bool)
            used[b] |= band.astype(bool)
        assert out, (a, b, "no segment")
        links.append({"layers": [a, b], "segments": out})
    return links, used


LINKS = [  # (layer A, layer B, "joint" | "each" | "chain", number of chain slices, erosion of the overlap in px)
    ("arm_r", "shirt", "joint", 0, 2), ("arm_l", "shirt", "joint", 0, 2),
    ("hand_r", "arm_r", "joint", 0, 2), ("hand_l", "arm_l", "joint", 0, 2),
    ("leg_r", "waist", "joint", 0, 2), ("leg_l", "waist", "joint", 0, 2),
    ("shoe_r", "leg_r", "joint", 0, 2), ("shoe_l", "leg_l", "joint", 0, 2),
    ("waist", "shirt", "joint", 0, 2),
    ("neck", "shirt", "chain", 8, 1),  # a thin crescent under the collar: short segments along it
    ("head", "neck", "joint", 0, 1),   # the chin over the top of the neck
    ("face", "head", "each", 0, 2), ("hair", "head", "joint", 0, 2),
    ("sleeve_r", "hand_r", "joint", 0, 2), ("sleeve_l", "hand_l", "joint", 0, 2),  # the cuff holds the wrist
    ("sleeve_r", "arm_r", "chain", 7, 2), ("sleeve_l", "arm_l", "chain", 7, 2),
    ("trouser_r", "leg_r", "chain", 7, 2), ("trouser_l", "leg_l", "chain", 7, 2),
]


def pin_at(mask, used, want, r=5):
    """The mask pixel centre nearest ``want`` that is r px inside the mask and off the link bands."""
    ok = erode(mask, r) & ~used
    ys, xs = np.nonzero(ok)
    P = np.stack([xs + 0.5, ys + 0.5], 1)
    p = P[np.argmin(np.linalg.norm(P - np.asarray(want, float), axis=1))]
    return [float(p[0]), float(p[1])]


def centroid(m):
    ys, xs = np.nonzero(m)
    return [xs.mean() + 0.5, ys.mean() + 0.5]


def build():
    write_mirrored()
    mask_files = write_masks()
    layers = layout()
    masks = {n: canvas_mask(img, off, mask_files) for n, img, off in layers}
    links, used = make_links(layers, masks, LINKS)
    # pins: hands, feet, hip, chest, head, and the shoulders (on the sleeves, where they
    # leave the shirt) that keep the top of an arm in front when its hand goes behind
    pins = []
    off = {n: o for n, _, o in layers}
    shoulder_r = [off["sleeve_r"][0] + 40, off["sleeve_r"][1] + 30]
    for name, layer in [("hand_l", "hand_l"), ("hand_r", "hand_r"), ("foot_l", "shoe_l"), ("foot_r", "shoe_r"),
                        ("hip", "waist"), ("chest", "shirt"), ("head", "head"),
                        ("shoulder_l", "sleeve_l"), ("shoulder_r", "sleeve_r")]:
        want = centroid(masks[layer])
        if name == "hip":
            want = [CX, want[1]]
        if name == "shoulder_r":
            want = shoulder_r
        if name == "shoulder_l":
            want = [CANVAS[0] - shoulder_r[0], shoulder_r[1]]
        pins.append({"name": name, "layer": layer, "at": pin_at(masks[layer], used[layer], want)})
    P = {p["name"]: p["at"] for p in pins}
    hl, hr, fr = P["hand_l"], P["hand_r"], P["foot_r"]
    n_layers = len(layers)
    poses = {
        "wave": {"hand_r": [hr[0] - 10, 95]},
        "kick": {"foot_r": [fr[0] + 80, fr[1] - 110]},
        "reach": {"hand_l": [hl[0] - 35, 215], "hand_r": [hr[0] + 35, 215]},
        "behind": {"hand_r": {"to": [232, 405], "depth": -float(n_layers)}},
    }
    scene = {
        "puppet": 1,
        "canvas": list(CANVAS),
        "background": BACKGROUND,
        "layers": [dict({"name": n, "image": img, "offset": off},
                        **({"mask": {"file": mask_files[os.path.basename(img)[:-4]]}}
                           if os.path.basename(img)[:-4] in mask_files else {}),
                        mesh={"max_area": MESH_AREA.get(n, MESH_AREA["*"])})
                   for n, img, off in layers],
        "links": links,
        "pins": pins,
        "poses": poses,
        "animation": {"fps": 24, "keys": [
            {"time": 0.0, "pose": "rest"},
            {"time": 0.4, "pose": "wave", "ease": "smooth"},
            {"time": 0.8, "pose": "reach", "ease": "smooth"},
            {"time": 1.2, "pose": "kick", "ease": "smooth"},
            {"time": 1.6, "pose": "behind", "ease": "smooth"},
            {"time": 2.0, "pose": "rest", "ease": "smooth"},
        ]},
    }
    return scene, layers



def preview(scene, layers, path):
    im = Image.new("RGBA", CANVAS, tuple(BACKGROUND))
    for n, img, off in layers:
        im.alpha_composite(Image.open(os.path.join(SCENES, img)).convert("RGBA"), tuple(off))
    draw_links_and_pins(ImageDraw.Draw(im), scene)
    im.save(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preview", help="also write a flat composite of the rest layout to this PNG")
    args = ap.parse_args()
    scene, layers = build()
    with open(OUT, "w") as f:
        f.write(dump(scene))
    print("wrote", os.path.relpath(OUT), "and", len(MIRRORED), "mirrored parts in", os.path.relpath(MIR))
    if args.preview:
        preview(scene, layers, args.preview)


if __name__ == "__main__":
    main()
