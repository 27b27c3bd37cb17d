"""Shared fixtures: small synthetic scenes written to a temporary folder."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest
from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ASSETS = os.path.join(ROOT, "assets")
SCENES = os.path.join(ASSETS, "scenes")
#: the app's native file dialogs cannot be clicked by a test: the path field instead
#: (inherited by the apps the tests start under Xvfb; see puppet/app/ui/files.py)
os.environ["PUPPET_FILE_DIALOG"] = os.environ.get("PUPPET_TEST_FILE_DIALOG", "field")


@pytest.fixture(autouse=True, scope="session")
def _config_home(tmp_path_factory):
    """The app's recent files go to a temporary config folder, never the user's."""
    os.environ["XDG_CONFIG_HOME"] = str(tmp_path_factory.mktemp("config"))


def write_rgba(path, rgba):
    Image.fromarray(np.asarray(rgba, np.uint8)).save(path)
    return path


def bar_image(w=120, h=40, box=(10, 10, 110, 30), colour=(200, 40, 40)):
    """An RGBA image, transparent but for one opaque rectangle (x0, y0, x1, y1)."""
    a = np.zeros((h, w, 4), np.uint8)
    x0, y0, x1, y1 = box
    a[y0:y1, x0:x1, :3] = colour
    a[y0:y1, x0:x1, 3] = 255
    return a


@pytest.fixture
def make_scene(tmp_path):
    """``make_scene(dict, images={name: rgba}) -> path`` writes images and the scene JSON."""

    def make(scene: dict, images: dict | None = None, name: str = "scene.json") -> str:
        for fname, rgba in (images or {}).items():
            write_rgba(tmp_path / fname, rgba)
        path = tmp_path / name
        path.write_text(json.dumps(scene))
        return str(path)

    return make


def bar_scene() -> dict:
    """A valid one-layer scene: a red bar with pins at both ends and a 'bend' pose."""
    return {
        "puppet": 1,
        "canvas": [120, 40],
        "background": [255, 255, 255, 255],
        "layers": [{"name": "bar", "image": "bar.png"}],
        "pins": [{"name": "left", "layer": "bar", "at": [15, 20]},
                 {"name": "right", "layer": "bar", "at": [105, 20]}],
        "poses": {"bend": {"right": [100, 5]}},
        "animation": {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "bend"}]},
    }


@pytest.fixture
def bar(make_scene):
    """Path of the valid bar scene (image included)."""
    return make_scene(bar_scene(), {"bar.png": bar_image()})
