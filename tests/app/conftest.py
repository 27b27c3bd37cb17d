"""App tests run in headless pyglet windows (EGL, no X server)."""
from __future__ import annotations

import pytest

from tests.app.harness import Driver
from tests.conftest import bar_image, bar_scene

# (no pytestmark here: in a conftest it marks nothing. Each test module is marked gl itself,
# and tests/conftest.py fails a test that makes a GL context without the mark)


@pytest.fixture
def bar_app(make_scene):
    """The app on the one-layer bar scene (pins left (15, 20) and right (105, 20), pose 'bend')."""
    d = Driver(make_scene(bar_scene(), {"bar.png": bar_image()}))
    yield d
    d.close()


@pytest.fixture
def two_bars(make_scene):
    """Two overlapping bars: 'red' behind, 'blue' in front, canvas 160x60."""
    from tests.conftest import bar_image as img

    scene = {"puppet": 1, "canvas": [160, 60], "background": [255, 255, 255, 255],
             "layers": [{"name": "red", "image": "red.png"},
                        {"name": "blue", "image": "blue.png", "offset": [40, 15]}],
             "pins": [{"name": "r1", "layer": "red", "at": [20, 20]},
                      {"name": "b1", "layer": "blue", "at": [100, 35]}]}
    path = make_scene(scene, {"red.png": img(160, 60, (10, 10, 150, 30), (200, 40, 40)),
                              "blue.png": img(120, 40, (10, 10, 110, 30), (40, 40, 200))})
    d = Driver(path)
    yield d
    d.close()
