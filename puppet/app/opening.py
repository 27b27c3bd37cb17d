"""Opening a scene, a picture or an autosave on the scene thread (File > Open)."""
from __future__ import annotations

import os

from puppet.errors import SceneError

#: ``puppet app FILE`` / File > Open with one of these opens a picture as a new scene
PICTURES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


def is_picture(path: str) -> bool:
    return os.path.splitext(path)[1].lower() in PICTURES


def load(path: str, *, picture: bool, recover_from: str | None = None):
    """The scene to open for ``path``: ``(scene, saved document or None, status message)``.

    A picture gives a new one-layer scene over it (the task script's Image step), saved
    later as ``NAME.json`` beside it; ``recover_from`` is an autosave opened in the
    scene's place (the file is unchanged until a save). The scene is built here (images,
    meshes, groups), not in the window's first frame.
    """
    import puppet

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
