"""Layers too small to mesh (issue 30, 7): the import's check agrees with the build that
``render`` runs, on tiny, thin and dusty layers; an import whose last rename fails
puts every file back (issue 30, 4)."""
from __future__ import annotations

import errno
import os

import numpy as np
import pytest

from puppet import output
from puppet.errors import SceneError
from puppet.imaging.layered import ArtLayer, LayeredArt
from puppet.output import OutputError, save_png
from puppet.scene.document.core import Document
from puppet.scene.make.art import _too_small, import_art, meshable
from tests.cli.test_init_safety import write_ora
from tests.fstree import snapshot


def shapes():
    rng = np.random.default_rng(7)
    out = []
    for w, h in [(1, 1), (2, 1), (2, 2), (3, 3), (2, 30), (1, 200), (3, 100), (4, 4), (5, 5), (8, 2)]:
        a = np.zeros((h, w, 4), np.uint8)
        a[..., 3] = 255
        out.append((f"solid{w}x{h}", a))
    for k in range(8):
        a = np.zeros((40, 40, 4), np.uint8)
        a[..., 3] = (rng.random((40, 40)) < rng.uniform(0.01, 0.3)) * 255
        out.append((f"dust{k}", a))
    a = np.zeros((50, 50, 4), np.uint8)
    np.fill_diagonal(a[..., 3], 255)
    out.append(("diagonal", a))
    return out


@pytest.mark.parametrize("name,rgba", shapes())
def test_too_small_is_what_the_build_refuses(tmp_path, name, rgba):
    save_png(str(tmp_path / "l.png"), rgba)
    doc = {"puppet": 1, "canvas": [300, 300], "layers": [
        {"name": name, "image": str(tmp_path / "l.png"), "offset": [5, 5], "mask": "alpha"}]}
    try:
        Document(doc, os.path.join(tmp_path, "s.json")).built  # noqa: B018
        refused = False
    except SceneError:
        refused = True
    assert _too_small(ArtLayer(name, rgba, (5, 5))) == refused


def test_meshable_leaves_them_out_with_a_note_or_refuses_all():
    """A layer of one pixel meshes (its outline runs round the whole pixel, see
    tests/cli/test_init_safety.py): kept. One without a pixel is left out with a note;
    only such layers: refused."""
    big = np.full((20, 20, 4), 255, np.uint8)
    dot = np.full((1, 1, 4), 255, np.uint8)
    empty = np.zeros((2, 2, 4), np.uint8)
    layers = [ArtLayer("big", big, (0, 0)), ArtLayer("dot", dot, (30, 30)), ArtLayer("empty", empty, (40, 40))]
    art, notes = meshable(LayeredArt("a.ora", (50, 50), layers))
    assert [lay.name for lay in art.layers] == ["big", "dot"]
    assert notes == ["layer 'empty' (2x2 px) is too small to mesh: left out"]
    with pytest.raises(SceneError, match="too small to mesh"):
        meshable(LayeredArt("a.ora", (50, 50), [ArtLayer("empty", empty, (30, 30))]))


def _ora(path, layers):
    write_ora(path, layers, canvas=(100, 100))


@pytest.mark.parametrize("update", [False, True])
def test_a_commit_that_fails_at_the_scene_puts_every_png_back(tmp_path, monkeypatch, update):
    """The PNGs are already renamed into the layers folder when the scene's rename fails:
    they are removed, the files they replaced put back, a folder made removed."""
    red, blue = np.zeros((20, 20, 4), np.uint8), np.zeros((20, 20, 4), np.uint8)
    red[..., 0], red[..., 3] = 255, 255
    blue[..., 2], blue[..., 3] = 255, 255
    art, scene = str(tmp_path / "a.ora"), str(tmp_path / "s.json")
    _ora(art, [("one", red, (10, 10)), ("two", red, (50, 50))])
    if update:
        import_art(art, scene)
        _ora(art, [("one", blue, (10, 10)), ("two", blue, (50, 50)), ("three", blue, (70, 10))])
    before = snapshot(str(tmp_path))
    commit = output.Staged.commit

    def failing(self):
        if self.target == os.path.realpath(scene):
            raise OSError(errno.ENOSPC, "No space left on device")
        commit(self)
    monkeypatch.setattr(output.Staged, "commit", failing)
    with pytest.raises(OutputError, match="No space left"):
        import_art(art, scene, update=update)
    assert snapshot(str(tmp_path)) == before
