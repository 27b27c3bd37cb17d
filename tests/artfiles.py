"""Layered art files made by the tests: a seven-part character (Kenney parts) saved as
PSD (with psd-tools' writer) and as ORA (a zip written here), with a hidden sketch layer
and a group of two legs."""
from __future__ import annotations

import io
import os
import zipfile

import numpy as np

ASSETS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "assets", "kenney-character")
CANVAS = (420, 600)

#: (name in the file, group or None, file under assets/kenney-character, offset), back to front.
PARTS = [
    ("arm_back", None, "mirrored/tint1_arm.png", (6, 226)),
    ("left", "legs", "tint1_leg.png", (122, 380)),
    ("right", "legs", "mirrored/tint1_leg.png", (205, 380)),
    ("body", None, "blueShirt1.png", (133, 222)),
    ("neck", None, "tint1_neck.png", (162, 224)),
    ("head", None, "tint1_head.png", (123, 66)),
    ("arm_front", None, "tint1_arm.png", (236, 226)),
]
#: The scene's layer names for PARTS, back to front.
NAMES = ["arm_back", "legs/left", "legs/right", "body", "neck", "head", "arm_front"]


def part(file: str) -> np.ndarray:
    from PIL import Image

    with Image.open(os.path.join(ASSETS, file)) as im:
        return np.asarray(im.convert("RGBA")).copy()


def parts(recolour: str | None = None) -> list[tuple[str, str | None, np.ndarray, tuple[int, int]]]:
    """(name, group, rgba, offset) back to front; ``recolour``: that part's colours inverted."""
    out = []
    for name, group, file, off in PARTS:
        rgba = part(file)
        if name == recolour:
            rgba[..., :3] = 255 - rgba[..., :3]
        out.append((name, group, rgba, off))
    return out


def sketch() -> np.ndarray:
    a = np.zeros((CANVAS[1], CANVAS[0], 4), np.uint8)
    a[::7, :, :3] = 90
    a[::7, :, 3] = 255
    return a


def composite(items) -> np.ndarray:
    """Straight-alpha composite (h, w, 4) uint8 of (rgba, offset) pairs, back to front."""
    from puppet.imaging.layered import ArtLayer, over

    return over([ArtLayer(str(i), rgba, off) for i, (rgba, off) in enumerate(items)], CANVAS)


def write_psd(path: str, recolour: str | None = None) -> None:
    from PIL import Image
    from psd_tools import PSDImage

    psd = PSDImage.new("RGBA", CANVAS, color=(0, 0, 0, 0))
    groups = {}
    items = parts(recolour)
    sk = psd.create_pixel_layer(Image.fromarray(sketch()), name="sketch")
    sk.visible = False
    for name, group, rgba, (x, y) in items:
        if group is not None and group not in groups:
            groups[group] = psd.create_group(name=group)
        parent = groups.get(group, psd)
        parent.create_pixel_layer(Image.fromarray(rgba), name=name, top=y, left=x)
    psd.save(path)


def tree_xml(items, open_group, close: str, leaf) -> list[str]:
    """XML lines for ``items`` (from :func:`parts`) top first, the group's element opened
    (``open_group(name)``) before its first layer and closed (``close``) after its last;
    ``leaf(k, name, rgba, x, y)`` gives a layer's element."""
    out, group_open = [], False
    for k, (name, group, rgba, (x, y)) in enumerate(reversed(items)):
        if bool(group) != group_open:
            out.append(open_group(group) if group else close)
            group_open = bool(group)
        out.append(leaf(k, name, rgba, x, y))
    if group_open:
        out.append(close)
    return out


def write_ora(path: str, recolour: str | None = None, *, extra: dict | None = None) -> None:
    """An OpenRaster file; ``extra``: more members (name -> bytes) for broken-file tests."""
    from PIL import Image

    def png(a):
        buf = io.BytesIO()
        Image.fromarray(a).save(buf, format="PNG")
        return buf.getvalue()

    items = parts(recolour)
    xml = ['<?xml version="1.0" encoding="UTF-8"?>', f'<image version="0.0.3" w="{CANVAS[0]}" h="{CANVAS[1]}">', "<stack>"]
    members = {}

    def leaf(k, name, rgba, x, y):
        members[f"data/{name}.png"] = png(rgba)
        return f'<layer name="{name}" src="data/{name}.png" x="{x}" y="{y}" opacity="1.0" visibility="visible"/>'
    xml += tree_xml(items, lambda g: f'<stack name="{g}">', "</stack>", leaf)
    members["data/sketch.png"] = png(sketch())
    xml.append('<layer name="sketch" src="data/sketch.png" x="0" y="0" visibility="hidden"/>')
    xml += ["</stack>", "</image>"]
    members["mergedimage.png"] = png(composite([(a, o) for _, _, a, o in items]))
    members.update(extra or {})
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
        z.writestr("stack.xml", "\n".join(xml))
        for k, v in members.items():
            z.writestr(k, v, compress_type=zipfile.ZIP_DEFLATED)


# -- any layer list, for the attack campaigns (tests/safety/campaign_layered.py) ----------------------
def write_psd_layers(path: str, items, canvas=CANVAS, *, version: int = 1, hidden=()) -> None:
    """A PSD (``version=2``: PSB) of ``items`` = (name, group or None, rgba, (x, y)) back to
    front; layers named in ``hidden`` are saved hidden."""
    from PIL import Image
    from psd_tools import PSDImage

    psd = PSDImage.new("RGBA", tuple(canvas), color=(0, 0, 0, 0))
    psd._record.header.version = version
    groups = {}
    for name, group, rgba, (x, y) in items:
        if group is not None and group not in groups:
            groups[group] = psd.create_group(name=group)
        layer = groups.get(group, psd).create_pixel_layer(Image.fromarray(rgba), name=name, top=y, left=x)
        if name in hidden:
            layer.visible = False
    psd.save(path)


def png_bytes(rgba: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="PNG")
    return buf.getvalue()


def write_ora_layers(path: str, items, canvas=CANVAS, *, extra: dict | None = None) -> None:
    """An OpenRaster file of ``items`` = (name, group or None, rgba, (x, y)) back to front
    (one PNG member per layer, names escaped in the XML); ``extra``: more members."""
    from xml.sax.saxutils import quoteattr

    members = {}

    def leaf(k, name, rgba, x, y):
        members[f"data/layer{k}.png"] = png_bytes(rgba)
        return f'<layer name={quoteattr(name)} src="data/layer{k}.png" x="{x}" y="{y}"/>'
    xml = [f'<?xml version="1.0" encoding="UTF-8"?><image version="0.0.3" w="{canvas[0]}" h="{canvas[1]}"><stack>']
    xml += tree_xml(items, lambda g: f"<stack name={quoteattr(g)}>", "</stack>", leaf)
    xml.append("</stack></image>")
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
        z.writestr("stack.xml", "\n".join(xml))
        for k, v in dict(members, **(extra or {})).items():
            z.writestr(k, v, compress_type=zipfile.ZIP_DEFLATED)


# -- characters for the automatic rig (issue 32) ------------------------------------------------------
ROBOT_CANVAS = (400, 560)


def _capsule(p, q, r, colour) -> np.ndarray:
    import cv2

    W, H = ROBOT_CANVAS
    a = np.zeros((H, W, 4), np.uint8)
    cv2.line(a, p, q, colour + (255,), 2 * r)
    cv2.circle(a, p, r, colour + (255,), -1)
    cv2.circle(a, q, r, colour + (255,), -1)
    return a


def _box(x0, y0, x1, y1, colour) -> np.ndarray:
    W, H = ROBOT_CANVAS
    a = np.zeros((H, W, 4), np.uint8)
    a[y0:y1, x0:x1] = colour + (255,)
    return a


def _cropped(a: np.ndarray):
    ys, xs = np.nonzero(a[..., 3])
    x0, y0 = int(xs.min()), int(ys.min())
    return a[y0:ys.max() + 1, x0:xs.max() + 1].copy(), (x0, y0)


def robot(generic: bool = False) -> list:
    """A blocky robot of 15 layers, (name, group, rgba, offset) back to front: legs (thigh,
    shin, foot) in groups ``left_leg``/``right_leg``, torso, neck, head, arms (upper_arm,
    forearm, square hand) in ``left_arm``/``right_arm``. The arms hang at the sides with each
    hand in front of its thigh: a hand overlaps its thigh (about 900 px) more than its
    wrist (about 260 px), as in the robot PSD of issue 32. ``generic``: layers named
    ``Layer 1``, ``Layer 2``, ... and no groups."""
    grey, dark, blue = (150, 160, 170), (90, 95, 110), (70, 120, 200)
    parts = []
    for side, s in (("left", -1), ("right", 1)):
        parts.append(("thigh", f"{side}_leg", _capsule((200 + s * 25, 330), (200 + s * 27, 420), 20, grey)))
        parts.append(("shin", f"{side}_leg", _capsule((200 + s * 27, 420), (200 + s * 28, 500), 17, grey)))
        x = 200 + s * 38
        parts.append(("foot", f"{side}_leg", _box(x - 22, 505, x + 22, 530, dark)))
    parts.append(("torso", None, _box(140, 150, 260, 340, blue)))
    parts.append(("neck", None, _box(186, 125, 214, 160, dark)))
    parts.append(("head", None, _box(160, 55, 240, 135, grey)))
    for side, s in (("left", -1), ("right", 1)):
        parts.append(("upper_arm", f"{side}_arm", _capsule((200 + s * 52, 170), (200 + s * 72, 250), 15, grey)))
        parts.append(("forearm", f"{side}_arm", _capsule((200 + s * 72, 250), (200 + s * 60, 332), 12, grey)))
        x = 200 + s * 47
        parts.append(("hand", f"{side}_arm", _box(x - 22, 330, x + 22, 374, dark)))
    out = [(name, group) + _cropped(a) for name, group, a in parts]
    if generic:
        out = [(f"Layer {k + 1}", None, a, off) for k, (_, _, a, off) in enumerate(out)]
    return out


#: The robot's layer names in the scene, back to front (``robot(generic=True)``: ``Layer 1``...).
ROBOT_NAMES = ["left_leg/thigh", "left_leg/shin", "left_leg/foot", "right_leg/thigh", "right_leg/shin",
               "right_leg/foot", "torso", "neck", "head", "left_arm/upper_arm", "left_arm/forearm", "left_arm/hand",
               "right_arm/upper_arm", "right_arm/forearm", "right_arm/hand"]

DRESSED_CANVAS = (601, 760)


def dressed(generic: bool = False) -> list:
    """A clothed Kenney character of 18 layers, (name, group, rgba, offset) back to front:
    neck, legs with trousers and shoes (groups ``left_leg``/``right_leg``), waist, shirt, arms
    under their sleeves with hands (``left_arm``/``right_arm``), head, face, hair.
    ``generic``: ``Layer 1``, ``Layer 2``, ... and no groups."""
    W = DRESSED_CANVAS[0]
    items = []

    def add(name, group, file, x, y, left=False, mirror=None):
        """``left``: placed mirrored about the canvas's middle, its picture mirrored too
        unless ``mirror`` says otherwise (a shoe points outwards on both sides)."""
        flip = left if mirror is None else mirror
        a = part(("mirrored/" if flip else "") + file)
        items.append((name, group, a, (W - x - a.shape[1] if left else x, y)))
    add("neck", None, "tint1_neck.png", 252, 289)
    for side in ("left", "right"):
        add("leg", f"{side}_leg", "tint1_leg.png", 300, 490, side == "left")
    for side in ("left", "right"):
        add("shoe", f"{side}_leg", "brownShoe5.png", 318, 640, side == "left", side == "right")
    for side in ("left", "right"):
        add("trousers", f"{side}_leg", "pantsLightBlue_long.png", 296, 486, side == "left")
    add("waist", None, "pantsLightBlue3.png", 224, 460)
    add("shirt", None, "redShirt1.png", 224, 296)
    for side in ("left", "right"):
        add("arm", f"{side}_arm", "tint1_arm.png", 345, 305, side == "left")
        add("sleeve", f"{side}_arm", "redArm_long.png", 343, 301, side == "left")
        add("hand", f"{side}_arm", "tint1_hand.png", 462, 400, side == "left")
    add("head", None, "tint1_head.png", 214, 128)
    add("face", None, "face1.png", 250, 175)
    add("hair", None, "brown2Man5.png", 215, 92)
    if generic:
        items = [(f"Layer {k + 1}", None, a, off) for k, (_, _, a, off) in enumerate(items)]
    return items
