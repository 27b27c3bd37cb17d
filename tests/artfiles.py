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
