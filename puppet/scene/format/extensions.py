"""Compatible extensions of scene format v1: keys that only the app reads.

``"app": {"underlay": {"image": "mannequin.jpg", "opacity": 0.5, "offset": [0, 0], "scale": 1.0}}``
stores a reference picture drawn under the canvas while editing (a garment placed over a
target photo). ``puppet render``, ``mesh`` and ``animate`` ignore it; it is validated
like every other key, so a typo is still an error.

``"app": {"art": "gbot.psd"}`` names the layered art file a scene was imported from
(``puppet init ART.psd``, ``puppet app ART.psd``), so that the app can offer "Reload
art" when that file changes; the file need not exist.
"""
from __future__ import annotations

import os

from puppet.scene.format.schema import (
    Ctx,
    expect_number,
    expect_object,
    expect_point,
    join,
)

UNDERLAY_DEFAULTS = {"opacity": 0.5, "offset": [0.0, 0.0], "scale": 1.0}


def parse_app(c: Ctx, v, p: str, file_path) -> dict:
    """The validated ``app`` object: ``{"underlay": {...}}`` with the image path absolute."""
    expect_object(c, v, p, optional=("underlay", "art"))
    out = {}
    if "art" in v:  # the layered art the scene was imported from (may have gone: not checked)
        out["art"] = file_path(v["art"], join(p, "art"))
    if "underlay" in v:
        q = join(p, "underlay")
        u = expect_object(c, v["underlay"], q, required=("image",), optional=("image", "opacity", "offset", "scale"))
        out["underlay"] = {
            "image": file_path(u["image"], join(q, "image")),
            "opacity": expect_number(c, u.get("opacity", 0.5), join(q, "opacity"), lo=0, hi=1),
            "offset": list(expect_point(c, u.get("offset", [0, 0]), join(q, "offset"))),
            "scale": expect_number(c, u.get("scale", 1.0), join(q, "scale"), lo=1e-3, hi=1e3, lo_open=True),
        }
    return out


def underlay_json(image: str, opacity: float, offset, scale: float) -> dict:
    """The ``app.underlay`` object as stored (absolute image path, defaults left out)."""
    u = {"image": os.path.abspath(image)}
    if opacity != UNDERLAY_DEFAULTS["opacity"]:
        u["opacity"] = float(opacity)
    if list(map(float, offset)) != UNDERLAY_DEFAULTS["offset"]:
        u["offset"] = [float(offset[0]), float(offset[1])]
    if scale != UNDERLAY_DEFAULTS["scale"]:
        u["scale"] = float(scale)
    return u
