"""The list of files a scene reads, which no output may overwrite."""
from __future__ import annotations

import os

from puppet.scene.format.inputs import input_files
from puppet.scene.format.load import load_scene_data
from tests.cli.outputs_helpers import make_bar


def test_every_kind_of_input_is_listed(tmp_path):
    scene = make_bar(tmp_path, mask=True, source=True, background=True)
    data = load_scene_data(scene)
    got = input_files(data)
    assert got == [(scene, "the scene file"), (str(tmp_path / "bg.png"), "background"),
                   (str(tmp_path / "source.png"), "source"), (str(tmp_path / "bar.png"), "layers[0].image"),
                   (str(tmp_path / "mask.png"), "layers[0].mask.file")]
    assert input_files(data, scene_file=False) == got[1:]


def test_the_apps_underlay_picture_is_an_input(tmp_path):
    data = load_scene_data(make_bar(tmp_path))
    data.raw = dict(data.raw, app={"underlay": {"image": "ref/person.jpg"}})
    assert input_files(data)[-1] == (os.path.join(str(tmp_path), "ref", "person.jpg"), "app.underlay.image")


def test_the_layered_art_a_scene_was_made_from_is_an_input(tmp_path):
    data = load_scene_data(make_bar(tmp_path))
    data.raw = dict(data.raw, app={"art": "../art/char.psd", "underlay": {"image": "u.png"}})
    assert input_files(data)[-2:] == [(os.path.join(str(tmp_path), "u.png"), "app.underlay.image"),
                                      (os.path.join(os.path.dirname(str(tmp_path)), "art", "char.psd"), "app.art")]
