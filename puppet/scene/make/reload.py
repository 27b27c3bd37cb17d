"""Reload art: the layered art a scene was imported from, merged again into the scene as
it is in memory (the app's File > Reload art), as one undo step.

The scene names its art in ``app.art`` (written by :func:`puppet.scene.make.art.import_art`).
The merge is :func:`puppet.scene.make.merge.merge`, the one ``puppet init ART --update``
runs (renamed layers matched by content, layers too small to mesh left out), applied to the open document instead of the file on disk: unsaved edits stay, the
new layer pixels are owned by the document until it is saved (written then into
``SCENE.files/`` like painted pixels), and undo brings back the old layers, pins and
links with their pixels. The art file is only read.
"""
from __future__ import annotations

import os

from puppet.errors import SceneError
from puppet.imaging.layered import read_layered
from puppet.scene.document.history import Event
from puppet.scene.make.art import ImportResult, art_of, layer_entry, meshable, safe_stem
from puppet.scene.make.merge import merge


def reload_art(scene):
    """Merge the scene's art file (``app.art``) into ``scene`` (a Document) as one undo
    step labelled "reload art"; returns the :class:`~puppet.scene.make.art.ImportResult`
    (``replaced``, ``added``, ``removed``, ``notes``: pins moved inside their layer, links
    and pins removed).

    Raises
    ------
    SceneError
        The scene names no art, the art is missing or unreadable, or the merged scene
        does not validate (the scene is unchanged then).
    """
    art_file = art_of(scene.to_dict(), scene.file)
    if art_file is None:
        raise SceneError("the scene names no art file (app.art): it was not imported from layered art",
                         file=scene.file)
    if not os.path.isfile(art_file):
        raise SceneError("the art file the scene was imported from is gone", file=art_file)
    art, small = meshable(read_layered(art_file))
    entries = {lay.name: layer_entry(lay, scene.pending.add(lay.rgba, safe_stem(lay.name)))  # a bounded file name
               for lay in art.layers}
    res = ImportResult(scene=scene.file or "", folder="", size=art.size,
                       layers=[lay.name for lay in art.layers], notes=list(art.notes) + small)

    def m(doc):
        new = merge(doc, art, entries, res)
        new["app"] = dict(new.get("app") or {}, art=art_file)
        doc.clear()
        doc.update(new)
    scene._edit(Event("layer", "", "mesh", "reload art"), m)  # validated (and meshed) first: all or nothing
    now = scene.to_dict()
    res.pins, res.links = len(now.get("pins", [])), len(now.get("links", []))
    return res
