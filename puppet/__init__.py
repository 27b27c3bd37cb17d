"""puppet: pose and animate 2D characters and garments made of overlapping layers.

>>> import puppet
>>> scene = puppet.load_scene("scene.json")
>>> rgba = scene.render(pose="reach")
"""
from puppet.errors import ImageError, SceneError

__version__ = "0.1.0"
__all__ = ["load_scene", "new_scene", "Scene", "SceneError", "ImageError", "deform", "__version__"]


def load_scene(path):
    """Read and validate a scene file (see ``docs/scene-format.md``); raises SceneError."""
    from puppet.api import load_scene as _load  # lazy: `import puppet` stays light (no numpy)

    return _load(path)


def new_scene(image, **options):
    """A new one-layer scene over a picture, not yet saved (see ``docs/api.md``)."""
    from puppet.api import new_scene as _new  # lazy: `import puppet` stays light (no numpy)

    return _new(image, **options)


def __getattr__(name):
    if name == "Scene":
        from puppet.api import Scene  # lazy: `import puppet` stays light (no numpy)

        return Scene
    if name == "deform":
        import importlib

        return importlib.import_module("puppet.deform")
    raise AttributeError(f"module 'puppet' has no attribute {name!r}")
