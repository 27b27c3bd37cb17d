"""Opening a scene, a picture, layered art or an autosave on the scene thread (File > Open,
a drop on the window, ``puppet app FILE``)."""
from __future__ import annotations

import os

import puppet
from puppet.errors import SceneError
from puppet.imaging.layered import is_layered
from puppet.scene.make.art import import_beside

#: ``puppet app FILE`` / File > Open with one of these opens a picture as a new scene
PICTURES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


def is_picture(path: str) -> bool:
    return os.path.splitext(path)[1].lower() in PICTURES


def is_art(path: str) -> bool:
    """A layered art file (.psd .psb .ora .kra): opened as the scene ``ART.json`` beside it."""
    return is_layered(path)


def scene_file(path: str) -> str:
    """The scene file that opening ``path`` shows: ``ART.json`` beside layered art, else ``path``."""
    return os.path.splitext(path)[0] + ".json" if is_art(path) else path


def check_exists(path: str) -> None:
    """SceneError unless ``path`` names a file (the first thing every open checks)."""
    if not os.path.exists(path):
        raise SceneError("no such file", file=path)
    if not os.path.isfile(path):
        raise SceneError("not a file (a scene .json, a picture or a layered .psd/.psb/.ora/.kra)", file=path)


def from_art(art: str):
    """``puppet app ART.psd``, File > Open or a drop of the art: the scene ``ART.json``
    beside it, made or updated (rig kept) by :func:`puppet.scene.make.art.import_beside`;
    returns its ImportResult (``.scene`` the path, ``.notes``, ``.summary()``)."""
    check_exists(art)
    return import_beside(art)


#: scenes loaded before the window opened (``puppet app FILE``), by absolute path
_preloaded: dict[str, tuple] = {}


def preload(path: str) -> str:
    """Load ``path`` as the window will (``puppet app FILE``) before any window opens, so a
    file that cannot be opened is one ``puppet: error:`` line and exit 2 (SceneError);
    :func:`load` then takes the scene loaded here. Art is imported first (its scene's
    path is returned; notes go to stderr, as ``puppet init`` prints them)."""
    import sys

    path = os.path.abspath(path)
    check_exists(path)
    if is_art(path):
        res = from_art(path)
        for line in res.note_lines(path):
            print(line, file=sys.stderr)
        print(res.summary(), file=sys.stderr)
        path = os.path.abspath(res.scene)
        _preloaded.clear()
        scene, saved, _ = load(path, picture=False)
        _preloaded[path] = (scene, saved, art_status(res))  # the status line says what the import did
        return path
    _preloaded.clear()
    _preloaded[path] = load(path, picture=is_picture(path))
    return path


def art_status(res) -> str:
    """The status line after layered art was imported: the summary, and the notes (the
    backup an update kept, renamed layers ...), also said on stderr."""
    if not res.notes:
        return res.summary()
    kept = [n for n in res.notes if "is kept in" in n]  # the backup first: what a user needs to know
    first = (kept or res.notes)[0]
    return res.summary() + f" ({len(res.notes)} note(s): {first}" + (" ...)" if len(res.notes) > 1 else ")")


def load(path: str, *, picture: bool, recover_from: str | None = None):
    """The scene to open for ``path``: ``(scene, saved document or None, status message)``.

    A picture gives a new one-layer scene over it (the task script's Image step), saved
    later as ``NAME.json`` beside it; ``recover_from`` is an autosave opened in the
    scene's place (the file is unchanged until a save). The scene is built here (images,
    meshes, groups), not in the window's first frame.
    """
    pre = _preloaded.pop(os.path.abspath(path), None)
    if pre is not None and recover_from is None:
        return pre
    check_exists(path)
    if is_art(path):  # File > Open or a drop of layered art: its scene beside it
        res = from_art(path)
        scene, saved, _ = load(os.path.abspath(res.scene), picture=False, recover_from=recover_from)
        return scene, saved, art_status(res)
    name = os.path.basename(path)
    if picture and recover_from is not None:  # the autosave of a scene made from this picture
        scene = puppet.load_scene(recover_from)
        scene.adopt_files(os.path.splitext(recover_from)[0] + ".files")  # saved into SCENE.files/
        scene.file = os.path.splitext(path)[0] + ".json"
        scene.built
        return scene, None, f"recovered the unsaved scene over {name} from its autosave"
    if picture:
        scene = puppet.new_scene(path)
        if os.path.exists(scene.file):
            raise SceneError(f"{os.path.basename(scene.file)} exists beside the picture: open it instead, "
                             "or move it away")
        scene.built
        return scene, None, f"new scene over {name}: set the first layer's mask (Image step)"
    scene = puppet.load_scene(path)
    saved = scene.to_dict()
    if recover_from is not None:
        scene = puppet.load_scene(recover_from)
        scene.adopt_files(os.path.splitext(recover_from)[0] + ".files")  # saved into SCENE.files/
        scene.file = path
    scene.built
    return scene, saved, f"opened {name}" + (" (recovered from its autosave)" if recover_from else "")
