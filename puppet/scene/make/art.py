"""``puppet init ART.psd|.psb|.ora|.kra``: a scene with one layer per visible layer of a
layered art file, and ``--update``: the same art re-imported into a rigged scene.

Each layer's pixels are written as a PNG in a folder named after the scene
(``SCENE-layers/``, one ``NAME.png`` per layer) and referenced with its ``offset``
and ``"mask": "alpha"``; the canvas is the document's size. ``pins="auto"`` pins every
layer at its skeleton's end points and junctions (pins named ``LAYER:end1``...);
``links="auto"`` proposes a link segment where two layers overlap
(:mod:`puppet.scene.make.auto_links`). With ``update`` the existing scene keeps its rig
(:mod:`puppet.scene.make.merge`).

Nothing is written unless the whole scene validates: the PNGs are written to a
temporary folder beside the scene, the scene is validated (and meshed when it has pins
or links) over them, then they are moved into place and the scene written last. The art
file is only read.
"""
from __future__ import annotations

import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.layered import ArtLayer, read_layered
from puppet.imaging.skeleton import auto_pins
from puppet.output import OutputError, check_file, write_text
from puppet.scene.document.core import Document
from puppet.scene.format.load import read_json
from puppet.scene.format.write import map_paths, scene_text
from puppet.scene.make import auto_links  # RIG_SECONDS, read when used
from puppet.scene.make.auto_links import Deadline, propose_links
from puppet.scene.make.merge import merge


@dataclass
class ImportResult:
    """What :func:`import_art` wrote and what it has to say."""

    scene: str
    folder: str
    size: tuple[int, int]
    layers: list[str]
    pins: int = 0
    links: int = 0
    notes: list[str] = field(default_factory=list)
    added: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)
    replaced: list[str] = field(default_factory=list)

    def note_lines(self, art: str) -> list[str]:
        """The notes as the command line prints them on stderr, one line each."""
        return [f"puppet: note: {art}: {note}" for note in self.notes]

    def summary(self) -> str:
        """One line for the command line."""
        w, h = self.size
        what = (f"{len(self.replaced)} replaced, {len(self.added)} added, {len(self.removed)} removed"
                if self.replaced or self.removed else f"{len(self.layers)} layer(s)")
        return (f"{self.scene}: {w}x{h}, {what}, {self.pins} pin(s), {self.links} link(s); "
                f"layer images in {self.folder}/")


def art_of(doc: dict, scene_file: str | None) -> str | None:
    """The absolute path of the art file a scene JSON (``doc``) names in ``app.art``, or None."""
    app = doc.get("app") if isinstance(doc, dict) else None
    art = app.get("art") if isinstance(app, dict) else None
    if not isinstance(art, str) or not art:
        return None
    return os.path.normpath(os.path.join(os.path.dirname(scene_file or ""), art))


def stamp(path: str | None) -> tuple[int, int] | None:
    """``(mtime_ns, size)`` of a file, or None when it cannot be read."""
    try:
        st = os.stat(path) if path else None
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size) if st else None


def layers_folder(scene: str) -> str:
    """The folder of a scene's layer images: ``SCENE-layers`` beside ``SCENE.json``."""
    return os.path.splitext(scene)[0] + "-layers"


def made_from(scene: str, art_file: str | None = None) -> bool:
    """Whether the scene file was made from layered art: it names ``art_file`` in
    ``app.art`` (a scene rigged, reloaded and saved in the app keeps its new pixels in
    ``SCENE.files/``), or every layer takes its image from the scene's layers folder (as
    :func:`import_art` writes it). False for an unreadable file."""
    try:
        doc = read_json(scene)
        images = [L.get("image") for L in doc["layers"]]
    except Exception:  # any unreadable or foreign file is "not made from the art"
        return False
    named = art_of(doc, os.path.abspath(scene))
    if art_file is not None and named is not None and _same_file(named, art_file):
        return True
    folder = os.path.basename(layers_folder(scene))
    return bool(images) and all(isinstance(p, str) and p.split("/")[0] == folder for p in images)


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def file_stem(name: str, taken: set[str]) -> str:
    """A file name (without ``.png``) for a layer name, unique (case-insensitively) in ``taken``."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name.replace("/", "__")).strip("._") or "layer"
    out, i = stem, 1
    while out.lower() in taken:
        i += 1
        out = f"{stem}-{i}"
    taken.add(out.lower())
    return out


def layer_entry(lay: ArtLayer, image: str) -> dict:
    """The scene's layer for an imported layer whose PNG is ``image``."""
    return {"name": lay.name, "image": image, "offset": [int(lay.offset[0]), int(lay.offset[1])], "mask": "alpha"}


def mask_of(lay: ArtLayer) -> np.ndarray:
    """(h, w) bool: the layer's pixels (alpha > 0), as its ``"alpha"`` mask selects them."""
    return lay.rgba[..., 3] > 0


def layer_pins(lay: ArtLayer, max_pins: int) -> list[dict]:
    """Pins at the skeleton's end points and junctions of a layer, in canvas coordinates."""
    ox, oy = lay.offset
    return [{"name": f"{lay.name}:{p.name}", "layer": lay.name,
             "at": [round(float(p.at[0]) + ox, 2), round(float(p.at[1]) + oy, 2)]}
            for p in auto_pins(mask_of(lay), max_pins=max_pins)]


def import_art(art_file: str, scene: str, *, pins: str = "none", links: str = "none",
               update: bool = False, max_pins: int = 8) -> ImportResult:
    """Write a scene over a layered art file, or re-import the art into it (``update``).

    Parameters
    ----------
    art_file : a ``.psd``, ``.psb``, ``.ora`` or ``.kra`` file.
    scene : the scene to write (``.json``); with ``update`` it must exist.
    pins : ``"auto"``: pin every layer (with ``update``: every layer that has no pin).
    links : ``"auto"``: propose a link where two layers overlap (and have none).
    max_pins : most automatic pins per layer.

    Raises
    ------
    SceneError
        Unreadable art, nothing visible, a scene to update that is missing or invalid,
        an output that cannot be written (nothing is written then).
    """
    shown, art_file, scene = scene, os.path.abspath(art_file), os.path.abspath(scene)
    inputs = [(art_file, "the art file")]
    check_file(scene, inputs=inputs, probe=True)
    folder = layers_folder(scene)
    if os.path.lexists(folder) and not os.path.isdir(folder):
        raise SceneError(f"{folder}: exists and is not a folder (the layer images go there)", file=shown)
    old = _old_scene(scene, shown) if update else None
    art = read_layered(art_file)
    names, taken = {}, set()
    for lay in art.layers:
        names[lay.name] = file_stem(lay.name, taken) + ".png"
    tmp = None
    try:
        tmp = tempfile.mkdtemp(prefix="." + os.path.basename(folder) + ".", dir=os.path.dirname(scene))
        doc, res = _document(art, old, tmp, names, pins=pins, links=links, max_pins=max_pins)
        res.scene, res.folder = shown, os.path.relpath(folder)
        _write_pngs(art.layers, tmp, names)
        _validate(doc, scene, mesh=bool(doc.get("pins") or doc.get("links")))
        final = _final(doc, tmp, folder, os.path.dirname(scene))
        _move_in(tmp, folder, names.values())
        _write_scene(scene, final, inputs)
    except OSError as e:  # a full disk or a folder that went away while writing
        raise OutputError(folder, e.strerror or str(e)) from None
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
    return res


def import_beside(art_file: str) -> ImportResult:
    """``puppet app ART.psd``: the scene ``ART.json`` beside the art, made from it with
    pins and links proposed, or, when it exists and was made from it (:func:`made_from`),
    updated from it (its rig kept). A scene of that name made otherwise is refused."""
    scene = os.path.splitext(art_file)[0] + ".json"
    update = os.path.exists(scene)
    if update and not made_from(scene, art_file):
        raise SceneError(f"{scene} exists and was not made from the art; open it, or make a new scene "
                         f"with 'puppet init {art_file} -o OTHER.json'", file=art_file)
    auto = "none" if update else "auto"
    return import_art(art_file, scene, pins=auto, links=auto, update=update)


def _old_scene(scene: str, shown: str) -> dict:
    if not os.path.exists(scene):
        raise SceneError("--update: there is no scene to update (leave out --update to make one)", file=shown)
    return Document.load(scene).to_dict()


def _document(art, old, tmp: str, names: dict, *, pins: str, links: str, max_pins: int):
    """The new scene (absolute paths into ``tmp``) and the result to report."""
    entries = {lay.name: layer_entry(lay, os.path.join(tmp, names[lay.name])) for lay in art.layers}
    res = ImportResult(scene="", folder="", size=art.size, layers=[lay.name for lay in art.layers],
                       notes=list(art.notes))
    if old is None:
        doc = {"puppet": 1, "canvas": list(art.size), "layers": list(entries.values())}
    else:
        doc = merge(old, art, entries, res)
    doc["app"] = dict(doc.get("app") or {}, art=os.path.abspath(art.path))  # what "Reload art" re-imports
    pinned = {p["layer"] for p in doc.get("pins", [])}
    budget = auto_links.RIG_SECONDS  # the automatic rig's time: half for pins when links follow
    told = []
    if pins == "auto":
        todo = [lay for lay in art.layers if lay.name not in pinned]
        deadline, new, done = Deadline(budget / 2 if links == "auto" else budget), [], 0
        for lay in todo:
            if deadline.passed():
                break
            new += layer_pins(lay, max_pins)
            done += 1
        doc["pins"] = doc.get("pins", []) + new
        budget = budget - deadline.seconds + deadline.left()
        told.append((deadline.hit, f"pins for {done} of {len(todo)} layers"
                     + (" (--update with --pins auto pins the rest)" if deadline.hit else "")))
    if links == "auto":
        linked = {frozenset(k["layers"]) for k in doc.get("links", [])}
        deadline = Deadline(budget)
        found = propose_links(art.layers, skip=linked, canvas=art.size, deadline=deadline)
        doc["links"] = doc.get("links", []) + found
        told.append((deadline.hit, f"{len(found)} link(s), for the largest overlaps only" if deadline.hit
                     else f"{len(found)} link(s)"))
    if any(hit for hit, _ in told):
        res.notes.append(f"automatic rig stopped after {auto_links.RIG_SECONDS:g} s: "
                         + ", ".join(what for _, what in told))
    res.pins, res.links = len(doc.get("pins", [])), len(doc.get("links", []))
    return doc, res


def _write_pngs(layers: list[ArtLayer], tmp: str, names: dict) -> None:
    import cv2

    for lay in layers:
        ok, png = cv2.imencode(".png", cv2.cvtColor(lay.rgba, cv2.COLOR_RGBA2BGRA))
        if not ok:
            raise SceneError(f"layer {lay.name!r}: OpenCV could not encode its PNG")
        with open(os.path.join(tmp, names[lay.name]), "wb") as f:
            f.write(png.data)


def _validate(doc: dict, scene: str, *, mesh: bool) -> None:
    """Load the scene as it will be; mesh it too (pins and link segments placed) when asked."""
    d = Document(doc, scene)
    if mesh:
        d.built  # noqa: B018  (pins outside their mesh, bad link segments fail here)


def _final(doc: dict, tmp: str, folder: str, scene_folder: str) -> dict:
    """The scene as written: image paths moved from ``tmp`` to ``folder``, all relative."""
    def fix(p: str) -> str:
        if os.path.dirname(p) == tmp:
            p = os.path.join(folder, os.path.basename(p))
        return os.path.relpath(p, scene_folder).replace(os.sep, "/")
    return map_paths(doc, fix)


def _move_in(tmp: str, folder: str, files) -> None:
    try:
        os.makedirs(folder, exist_ok=True)
        for name in files:
            os.replace(os.path.join(tmp, name), os.path.join(folder, name))
    except OSError as e:
        raise OutputError(folder, e.strerror or str(e)) from None


def _write_scene(scene: str, doc: dict, inputs) -> None:
    write_text(scene, scene_text(doc), inputs=inputs)
