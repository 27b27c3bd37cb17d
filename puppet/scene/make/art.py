"""``puppet init ART.psd|.psb|.ora|.kra``: a scene with one layer per layer of a layered
art file (hidden ones kept hidden, ``"visible": false``), and ``--update``: the same art
re-imported into a rigged scene.

Each layer's pixels are written as a PNG in a folder named after the scene
(``SCENE-layers/``, one ``NAME.png`` per layer) and referenced with its ``offset``
and ``"mask": "alpha"``; the canvas is the document's size. ``pins="auto"`` and
``links="auto"`` rig the parts by anatomy (:mod:`puppet.scene.make.anatomy`): hinges
where limbs join the torso or their parent limb, segments where a part is painted on
another, pins at the torso, the shoulders and hips and the free ends. With ``update`` the existing scene keeps its rig
(:mod:`puppet.scene.make.merge`).

Nothing is written unless the whole scene validates: the PNGs are written to a
temporary folder beside the scene, the scene is validated (and meshed when it has pins
or links) over them, then they are moved into place and the scene written last. The art
file is only read.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import shutil
import stat
import time
from dataclasses import dataclass, field

import numpy as np

from puppet.errors import SceneError
from puppet.geom.contour import mask_regions
from puppet.geom.triangulate import triangulate_regions
from puppet.imaging.layered import ArtLayer, LayeredArt, read_layered
from puppet.output import OutputError, Staged, check_file, commit_into, drop_staging, staging_folder
from puppet.scene.document.core import Document
from puppet.scene.format.inputs import input_files
from puppet.scene.format.load import read_json
from puppet.scene.format.model import MeshOptions
from puppet.scene.format.write import map_paths, relative_to, scene_text
from puppet.scene.make import auto_links  # RIG_SECONDS, read when used
from puppet.scene.make.anatomy import RIG_DEFORMER, propose_rig
from puppet.scene.make.auto_links import Deadline
from puppet.scene.make.merge import merge
from puppet.scene.rig.build import default_max_area


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


#: Longest layer file name (UTF-8 bytes, ``.png`` included): well under NAME_MAX (255),
#: with room for the temporary and aside names built from it.
MAX_FILE_NAME = 100
#: The import's manifest in the layers folder: what the import wrote (name -> content hash).
MANIFEST = ".puppet-import.json"


def safe_stem(name: str) -> str:
    """A layer name as a file stem: ``/`` as ``__``, other characters than letters, digits,
    ``_ . -`` as ``_``; when longer than fits :data:`MAX_FILE_NAME`, cut and ended with a
    short hash of the whole name (so two long names that share a beginning differ)."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name.replace("/", "__")).strip("._") or "layer"
    room = MAX_FILE_NAME - len(".png") - len("-12345678-99")  # a hash and a counter may follow
    if len(stem) > room:
        stem = stem[:room - 9].rstrip("._") + "-" + _short_hash(name)
    return stem


def _short_hash(name: str) -> str:
    return hashlib.sha1(name.encode("utf-8", "surrogatepass")).hexdigest()[:8]


def file_stem(name: str, taken: set[str]) -> str:
    """A file name (without ``.png``) for a layer name, unique (case-insensitively) in
    ``taken``, at most :data:`MAX_FILE_NAME` bytes with the suffix, the same for the
    same name and ``taken``."""
    stem = safe_stem(name)
    out = stem
    if out.lower() in taken:
        out = f"{stem}-{_short_hash(name)}"
    i = 1
    while out.lower() in taken:
        i += 1
        out = f"{stem}-{_short_hash(name)}-{i}"
    taken.add(out.lower())
    return out


def layer_entry(lay: ArtLayer, image: str) -> dict:
    """The scene's layer for an imported layer whose PNG is ``image`` (a layer the file
    hides is kept with ``"visible": false``)."""
    entry = {"name": lay.name, "image": image, "offset": [int(lay.offset[0]), int(lay.offset[1])], "mask": "alpha"}
    if not lay.visible:
        entry["visible"] = False
    return entry


def mask_of(lay: ArtLayer) -> np.ndarray:
    """(h, w) bool: the layer's pixels (alpha > 0), as its ``"alpha"`` mask selects them."""
    return lay.rgba[..., 3] > 0


def import_art(art_file: str, scene: str, *, pins: str = "none", links: str = "none",
               update: bool = False, max_pins: int = 8, force: bool = False) -> ImportResult:
    """Write a scene over a layered art file, or re-import the art into it (``update``).

    Parameters
    ----------
    art_file : a ``.psd``, ``.psb``, ``.ora`` or ``.kra`` file.
    scene : the scene to write (``.json``); with ``update`` it must exist.
    pins : ``"auto"``: pin every layer (with ``update``: every layer that has no pin).
    links : ``"auto"``: propose a link where two layers overlap (and have none).
    max_pins : most automatic pins per layer.
    force : replace files in the layers folder that an earlier import of this scene did
        not write (or that were edited since), and symlinks there (the link, never its target).

    The layer images go to ``SCENE-layers/`` (never a symlink), named by
    :func:`file_stem`; the folder's manifest (:data:`MANIFEST`) records what the import
    wrote, so a later import replaces only those files. With ``update`` the scene as it
    was is kept first (:func:`backup_path`), a file the scene reads is never replaced,
    and renamed layers are matched by content (:func:`puppet.scene.make.merge.merge`).
    Layers too small to mesh are left out with a note. PNGs, manifest, backup and scene
    are staged and put in place together, or nothing is.

    Raises
    ------
    SceneError
        Unreadable art, nothing visible, a scene to update that is missing or invalid,
        a file in the way (without ``force``), an output that cannot be written
        (nothing is written then).
    """
    shown, art_file, scene = scene, os.path.abspath(art_file), os.path.abspath(scene)
    inputs = [(art_file, "the art file")]
    check_file(scene, inputs=inputs, probe=True)
    folder = layers_folder(scene)
    if os.path.islink(folder):
        raise SceneError(f"{folder}: is a symbolic link; puppet never writes the layer images through a link "
                         "(remove it, or give another -o)", file=shown)
    if os.path.lexists(folder) and not os.path.isdir(folder):
        raise SceneError(f"{folder}: exists and is not a folder (the layer images go there)", file=shown)
    old = _old_scene(scene, shown) if update else None
    owned = read_manifest(folder, old if old is not None else _existing(scene))
    reads = _read_by(old, folder, owned)
    art = read_layered(art_file)
    art, small = meshable(art)
    names = _file_names(art.layers, owned, reads)
    _check_way(folder, list(names.values()) + [MANIFEST], owned, force=force)
    tmp = staging_folder(folder)
    try:
        doc, res = _document(art, old, tmp, names, pins=pins, links=links, max_pins=max_pins)
        res.notes += small
        res.scene, res.folder = shown, os.path.relpath(folder)
        written = _write_pngs(art.layers, tmp, names)
        _validate(doc, scene, mesh=bool(doc.get("pins") or doc.get("links")))
        final = _final(doc, tmp, folder, scene)
        _write_manifest(tmp, folder, owned, written, names)
        after: list[Staged] = []
        try:
            if old is not None:
                bak = backup_path(scene)
                if _same_bytes(scene, scene + ".bak"):  # the copy an earlier update kept is this scene
                    bak = scene + ".bak"
                else:
                    after.append(_copy_staged(scene, bak))
                res.notes.append(f"the scene as it was is kept in {os.path.relpath(bak)}")
            text = scene_text(final)
            after.append(Staged(scene, lambda t: _write(t, text), inputs=inputs))
            commit_into(folder, tmp, list(names.values()) + [MANIFEST], after)
        except BaseException:
            for s in after:  # staged but not committed (no-op for those commit_into dealt with)
                s.discard()
            raise
    except OSError as e:  # a full disk or a folder that went away while writing
        raise OutputError(folder, e.strerror or str(e)) from None
    finally:
        drop_staging(tmp)
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


def backup_path(scene: str) -> str:
    """Where ``--update`` keeps the scene it replaces: ``SCENE.json.bak``, or, when that
    exists, ``SCENE.json.YYYYmmdd-HHMMSS.bak`` (``-2``, ``-3``... when that exists too)."""
    bak = scene + ".bak"
    if not os.path.lexists(bak):
        return bak
    stamp_ = time.strftime("%Y%m%d-%H%M%S")
    bak, i = f"{scene}.{stamp_}.bak", 1
    while os.path.lexists(bak):
        i += 1
        bak = f"{scene}.{stamp_}-{i}.bak"
    return bak


def read_manifest(folder: str, old: Document | None = None) -> dict[str, dict]:
    """What earlier imports wrote in the layers folder: file name -> ``{"layer": name,
    "sha256": hex}``. Without a manifest, the layer images that ``old`` (the scene at the
    output, made by an import before manifests existed: it names its art in ``app.art``)
    takes from the folder are taken as written by that import."""
    data = _manifest_data(os.path.join(folder, MANIFEST))
    if data is not None:
        try:
            return {n: {"layer": str(e["layer"]), "sha256": str(e["sha256"])} for n, e in data["files"].items()
                    if isinstance(n, str) and _plain_name(n)}
        except (KeyError, TypeError, AttributeError):
            pass
    owned = {}
    doc = old.to_dict() if old is not None else {}
    if art_of(doc, old.file if old is not None else None) and not os.path.lexists(os.path.join(folder, MANIFEST)):
        for L in doc.get("layers", []):  # only a scene an import made (it names its art) owns its images
            p = L.get("image")
            if isinstance(p, str) and os.path.dirname(p) == folder and os.path.isfile(p) and not os.path.islink(p):
                owned[os.path.basename(p)] = {"layer": L["name"], "sha256": _sha256_file(p)}
    return owned


def meshable(art: LayeredArt) -> tuple[LayeredArt, list[str]]:
    """The art without the layers the scene could not mesh (a pixel or two: ``render``
    would refuse the scene), and a note for each one left out."""
    kept, notes = [], []
    for lay in art.layers:
        if _too_small(lay):
            h, w = lay.rgba.shape[:2]
            notes.append(f"layer {lay.name!r} ({w}x{h} px) is too small to mesh: left out")
        else:
            kept.append(lay)
    if not kept:
        raise SceneError("every visible layer is too small to mesh (a pixel or two): nothing to import",
                         file=art.path)
    return dataclasses.replace(art, layers=kept), notes


def _too_small(lay: ArtLayer) -> bool:
    """Whether the layer's alpha mask gives no triangle with the scene's default mesh
    options, as :func:`puppet.scene.rig.build.mesh_layer` meshes it (what ``render``
    refuses). A mask holding a solid 5x5 block always meshes; only the others (a few
    pixels, thin lines, dust) are triangulated here."""
    mask = mask_of(lay)
    if not mask.any():
        return True
    import cv2  # lazy: OpenCV, with numpy already loaded by the reader

    if cv2.erode(mask.astype(np.uint8), np.ones((5, 5), np.uint8), borderValue=0).any():
        return False
    opts = MeshOptions()
    try:
        mesh = triangulate_regions(mask_regions(mask, lay.offset), max_area=default_max_area(mask),
                                   min_angle=opts.min_angle, simplify=opts.simplify)
    except Exception:  # any other failure is the build's to report, with its JSON path
        return False
    return len(mesh.F) == 0


def _old_scene(scene: str, shown: str) -> Document:
    if not os.path.exists(scene):
        raise SceneError("--update: there is no scene to update (leave out --update to make one)", file=shown)
    return Document.load(scene)


def _existing(scene: str) -> Document | None:
    """The scene already at the output, when it loads (an import made before manifests
    existed, run again without ``--update``), else None."""
    if not os.path.isfile(scene) or os.path.lexists(os.path.join(layers_folder(scene), MANIFEST)):
        return None
    try:
        return Document.load(scene)
    except Exception:  # any scene that does not load owns nothing
        return None


def _plain_name(name: str) -> bool:
    return bool(name) and "/" not in name and "\0" not in name and name not in (".", "..") \
        and len(name.encode("utf-8", "surrogatepass")) <= 255


def _sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _read_by(old: Document | None, folder: str, owned: dict) -> set[str]:
    """Lower-cased names of the files in ``folder`` that the old scene reads and that no
    import wrote (a stiffness or mask image put there by the user): never replaced."""
    if old is None:
        return set()
    out = set()
    for path, _ in input_files(old.data):
        if os.path.dirname(os.path.abspath(path)) == folder and os.path.basename(path) not in owned:
            out.add(os.path.basename(path).lower())
    return out


def _file_names(layers: list[ArtLayer], owned: dict, reads: set[str]) -> dict[str, str]:
    """Layer name -> PNG name: the one an earlier import gave the layer (stable across
    re-imports), else :func:`file_stem`; never a name the old scene reads otherwise."""
    def stem(n: str) -> str | None:
        return n[:-4].lower() if n.lower().endswith(".png") else None
    earlier = {e["layer"]: n for n, e in sorted(owned.items())}
    taken = {stem(n) for n in reads} - {None}  # file_stem compares stems (lower case)
    names = {}
    for lay in layers:  # the names kept first, so a new layer never takes one
        n = earlier.get(lay.name)
        if n and stem(n) and stem(n) not in taken and len(n.encode()) <= MAX_FILE_NAME:
            names[lay.name] = n
            taken.add(stem(n))
    for n, e in owned.items():  # an old layer's file is not given to a new layer of another name
        if e["layer"] not in names and stem(n):
            taken.add(stem(n))
    for lay in layers:
        if lay.name not in names:
            names[lay.name] = file_stem(lay.name, taken) + ".png"
    return {lay.name: names[lay.name] for lay in layers}


def _check_way(folder: str, files: list[str], owned: dict, *, force: bool) -> None:
    """Refuse (unless ``force``) to replace a file at one of ``files`` in ``folder`` that
    no import of this scene wrote, or that was changed since (content hash), and any
    symlink there; a folder or other non-file there is always refused."""
    for name in files:
        path = os.path.join(folder, name)
        if not os.path.lexists(path):
            continue
        if os.path.islink(path):
            why = "is a symbolic link"
        elif not os.path.isfile(path):
            raise SceneError("is in the way of a file the import writes and is not a file; move it away", file=path)
        elif name == MANIFEST:
            why = None if owned or _is_manifest(path) else "is not a manifest puppet wrote"
        elif name not in owned:
            why = "was not written by an import of this scene"
        elif _sha256_file(path) != owned[name]["sha256"]:
            why = "was changed since the import wrote it"
        else:
            why = None
        if why and not force:
            raise SceneError(f"{why}; puppet will not replace it (give --force to replace it)", file=path)


def _manifest_data(path: str) -> dict | None:
    """The manifest's JSON object, or None: missing, not a regular file (a link, a FIFO:
    never opened), over 16 MiB or not a JSON object with ``files``."""
    try:
        st = os.lstat(path)
        if not stat.S_ISREG(st.st_mode) or st.st_size > 1 << 24:
            return None
        with open(path, "rb") as f:
            data = json.loads(f.read(1 << 24).decode("utf-8"))
    except Exception:  # unreadable, not UTF-8, not JSON, nested past the recursion limit: not a manifest
        return None
    return data if isinstance(data, dict) and isinstance(data.get("files"), dict) else None


def _is_manifest(path: str) -> bool:
    return _manifest_data(path) is not None


def _write_manifest(tmp: str, folder: str, owned: dict, written: dict, names: dict) -> None:
    """The manifest for the folder after the import: what it writes now, with what earlier
    imports wrote that is still there unchanged (images of layers the art no longer has)."""
    files = {}
    for n, e in owned.items():
        p = os.path.join(folder, n)
        if n not in written and os.path.isfile(p) and not os.path.islink(p) and _sha256_file(p) == e["sha256"]:
            files[n] = e
    layer_of = {v: k for k, v in names.items()}
    for n, digest in written.items():
        files[n] = {"layer": layer_of[n], "sha256": digest}
    text = json.dumps({"puppet-import": 1, "files": dict(sorted(files.items()))}, indent=1, ensure_ascii=False)
    _write(os.path.join(tmp, MANIFEST), text + "\n")


def _same_bytes(a: str, b: str) -> bool:
    """Whether two regular files (not links) hold the same bytes."""
    try:
        if os.path.islink(b) or not os.path.isfile(b) or os.path.getsize(a) != os.path.getsize(b):
            return False
        return _sha256_file(a) == _sha256_file(b)
    except OSError:
        return False


def _copy_staged(scene: str, bak: str) -> Staged:
    """The scene file's bytes staged at ``bak`` (a name puppet chose: never through a link)."""
    def write(t: str) -> None:
        shutil.copyfile(scene, t)
    return Staged(bak, write, inputs=[(scene, "the scene file")], follow=False)


def _write(path: str, text: str) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def _document(art, old, tmp: str, names: dict, *, pins: str, links: str, max_pins: int):
    """The new scene (absolute paths into ``tmp``) and the result to report."""
    entries = {lay.name: layer_entry(lay, os.path.join(tmp, names[lay.name])) for lay in art.layers}
    res = ImportResult(scene="", folder="", size=art.size, layers=[lay.name for lay in art.layers],
                       notes=list(art.notes))
    if old is None:
        doc = {"puppet": 1, "canvas": list(art.size), "layers": list(entries.values())}
    else:
        doc = merge(old.to_dict(), art, entries, res)
    doc["app"] = dict(doc.get("app") or {}, art=os.path.abspath(art.path))  # what "Reload art" re-imports
    if pins == "auto" or links == "auto":
        _auto_rig(doc, art, res, pins=pins == "auto", links=links == "auto", max_pins=max_pins)
    res.pins, res.links = len(doc.get("pins", [])), len(doc.get("links", []))
    return doc, res


def _auto_rig(doc: dict, art, res: ImportResult, *, pins: bool, links: bool, max_pins: int) -> None:
    """Add the anatomy rig (:mod:`puppet.scene.make.anatomy`) to ``doc``: its pins on layers
    that have none (at most ``max_pins`` each), its links between layers not linked yet.
    Hidden layers get neither (a hidden sketch is no part)."""
    pinned = {p["layer"] for p in doc.get("pins", [])}
    linked = {frozenset(k["layers"]) for k in doc.get("links", [])}
    deadline = Deadline(auto_links.RIG_SECONDS)
    rig = propose_rig([lay for lay in art.layers if lay.visible], canvas=art.size, skip=linked, deadline=deadline)
    new_pins, per = [], {}
    for p in rig.pins if pins else []:
        per[p["layer"]] = per.get(p["layer"], 0) + 1
        if p["layer"] not in pinned and per[p["layer"]] <= max_pins:
            new_pins.append(p)
    new_links = [k for k in rig.links if frozenset(k["layers"]) not in linked] if links else []
    if pins:
        doc["pins"] = doc.get("pins", []) + new_pins
    if new_pins and new_links and "deformer" not in doc:
        doc["deformer"] = dict(RIG_DEFORMER)
    if links:
        doc["links"] = doc.get("links", []) + new_links
    if deadline.hit:
        res.notes.append(f"automatic rig stopped after {auto_links.RIG_SECONDS:g} s: "
                         f"{len(new_pins)} pin(s) and {len(new_links)} link(s) for the parts done "
                         "(--update with --pins auto --links auto rigs the rest)")


def _write_pngs(layers: list[ArtLayer], tmp: str, names: dict) -> dict[str, str]:
    """Encode every layer's PNG into ``tmp``; returns file name -> SHA-256 of what was written."""
    import cv2  # lazy: OpenCV, for the PNG encoder only

    written = {}
    for lay in layers:
        ok, png = cv2.imencode(".png", cv2.cvtColor(lay.rgba, cv2.COLOR_RGBA2BGRA))
        if not ok:
            raise SceneError(f"layer {lay.name!r}: OpenCV could not encode its PNG")
        data = png.tobytes()
        with open(os.path.join(tmp, names[lay.name]), "wb") as f:
            f.write(data)
        written[names[lay.name]] = hashlib.sha256(data).hexdigest()
    return written


def _validate(doc: dict, scene: str, *, mesh: bool) -> None:
    """Load the scene as it will be; build it too (images, masks, meshes, pins and link
    segments placed: what ``render`` needs) when asked."""
    d = Document(doc, scene)
    if mesh:
        d.built  # noqa: B018  (a layer too small to mesh, pins outside their mesh, bad link segments fail here)


def scene_paths(scene: str):
    """``fn(path) -> str``: a path as written in the scene file ``scene``: relative where it
    names the same file from the scene's folder as given and from the real folder of the
    file (``scene`` may be a symlink into another folder: it loads by either path), else
    absolute (see :func:`~puppet.scene.format.write.relative_to`)."""
    given = relative_to(os.path.dirname(os.path.abspath(scene)))
    real = relative_to(os.path.dirname(os.path.realpath(scene)))

    def rel(p: str) -> str:
        r = given(p)
        return r if r == real(p) else os.path.abspath(p).replace(os.sep, "/")
    return rel


def _final(doc: dict, tmp: str, folder: str, scene: str) -> dict:
    """The scene as written: image paths moved from ``tmp`` to ``folder``, relative to the
    scene as the loader resolves them (:func:`scene_paths`)."""
    rel = scene_paths(scene)

    def fix(p: str) -> str:
        if os.path.dirname(p) == tmp:
            p = os.path.join(folder, os.path.basename(p))
        return rel(p)
    return map_paths(doc, fix)
