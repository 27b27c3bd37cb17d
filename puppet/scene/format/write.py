"""Writing a scene file: the one text form every writer uses (``Document.save``, ``puppet
init``, layered-art import), and the file paths inside a scene, mapped or made relative.

The text is JSON, indented by one space per level, where every value that fits on one
line of :data:`WIDTH` columns is written on one line: a pin, a point, a short pose or
key stays one line, a layer list or a long animation is spread over lines.
"""
from __future__ import annotations

import json
import os
from collections.abc import Callable

#: columns a line may take (indentation, key and the comma after a value included),
#: unless it holds one value that cannot be split
WIDTH = 100


def scene_text(doc: dict) -> str:
    """The scene JSON as text, ending with a newline."""
    return _value(doc, 0, 0) + "\n"


def _value(v, indent: int, used: int) -> str:
    """``v`` as JSON text starting ``used`` columns into a line indented ``indent`` spaces."""
    flat = json.dumps(v)
    if used + len(flat) < WIDTH or not isinstance(v, (dict, list)) or not v:
        return flat
    pad = " " * (indent + 1)
    if isinstance(v, dict):
        rows = []
        for k, x in v.items():
            key = f"{pad}{json.dumps(k)}: "
            rows.append(key + _value(x, indent + 1, len(key)))
    else:
        rows = [pad + _value(x, indent + 1, len(pad)) for x in v]
    close = "}" if isinstance(v, dict) else "]"
    return ("{" if isinstance(v, dict) else "[") + "\n" + ",\n".join(rows) + "\n" + " " * indent + close


def map_paths(doc: dict, fn: Callable[[str], str]) -> dict:
    """A shallow-copied scene JSON with every file path replaced by ``fn(path)``."""
    doc = dict(doc)
    for key in ("source", "background"):
        if isinstance(doc.get(key), str):
            doc[key] = fn(doc[key])
    app = doc.get("app")
    if isinstance(app, dict) and isinstance(app.get("underlay"), dict) and isinstance(app["underlay"].get("image"), str):
        doc["app"] = dict(app, underlay=dict(app["underlay"], image=fn(app["underlay"]["image"])))
    app = doc.get("app")
    if isinstance(app, dict) and isinstance(app.get("art"), str):
        doc["app"] = dict(app, art=fn(app["art"]))
    if not isinstance(doc.get("layers"), list):
        return doc
    layers = []
    for L in doc["layers"]:
        if isinstance(L, dict):
            L = dict(L)
            if isinstance(L.get("image"), str):
                L["image"] = fn(L["image"])
            if isinstance(L.get("mask"), dict) and isinstance(L["mask"].get("file"), str):
                L["mask"] = dict(L["mask"], file=fn(L["mask"]["file"]))
            if isinstance(L.get("stiffness"), dict) and isinstance(L["stiffness"].get("file"), str):
                L["stiffness"] = dict(L["stiffness"], file=fn(L["stiffness"]["file"]))
        layers.append(L)
    doc["layers"] = layers
    return doc


def relative_to(folder: str) -> Callable[[str], str]:
    """A path as written in a scene saved in ``folder``: relative to it as the loader
    resolves it (lexically, from the path as given: a symlinked folder stays in the
    path), with forward slashes; absolute when the relative path would name another file
    from the folder's real place (it climbs out of a symlinked folder)."""
    folder = os.path.abspath(folder)
    real = os.path.realpath(folder)

    def rel(p: str) -> str:
        r = os.path.relpath(p, folder)
        if os.path.realpath(os.path.join(real, r)) != os.path.realpath(p):
            r = p
        return r.replace(os.sep, "/")
    return rel
