"""The files a scene reads, so that no output ever overwrites one of them."""
from __future__ import annotations

import os

from puppet.scene.format.model import SceneData


def input_files(data: SceneData, *, scene_file: bool = True) -> list[tuple[str, str]]:
    """Every file the scene reads, with what it is.

    Parameters
    ----------
    data : the validated scene (paths are absolute).
    scene_file : include the scene file itself (False when saving the scene over itself).

    Returns
    -------
    list of (path, description), e.g. ``("/a/arm.png", "layers[1].image")``, in scene order.
    """
    out: list[tuple[str, str]] = []
    if scene_file and data.file:
        out.append((data.file, "the scene file"))
    if isinstance(data.background, str):
        out.append((data.background, "background"))
    if data.source:
        out.append((data.source, "source"))
    for i, layer in enumerate(data.layers):
        if layer.image:
            out.append((layer.image, f"layers[{i}].image"))
        mask = layer.mask
        if mask is not None and getattr(mask, "file", None):
            out.append((mask.file, f"layers[{i}].mask.file"))
        if getattr(layer, "stiffness", None):
            out.append((layer.stiffness, f"layers[{i}].stiffness.file"))
    app = _app(data)
    u = app.get("underlay")
    for path, what in ((u.get("image") if isinstance(u, dict) else None, "app.underlay.image"),
                       (app.get("art"), "app.art")):
        if isinstance(path, str) and path:
            out.append((os.path.normpath(os.path.join(os.path.dirname(data.file or ""), path)), what))
    return out


def _app(data: SceneData) -> dict:
    """The scene's ``app`` block (the app's reference picture ``underlay.image``, the
    layered ``art`` file "Reload art" re-imports), or an empty dict."""
    app = getattr(data, "app", None)
    if not isinstance(app, dict):
        raw = getattr(data, "raw", None)
        app = raw.get("app") if isinstance(raw, dict) else None
    return app if isinstance(app, dict) else {}
