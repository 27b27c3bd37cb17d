"""Issue 20 (8, 9) through the API: a scene saved into a folder reached through a symlink
loads from the link and from the real folder; a save with painted pixels on a full disk
leaves nothing (no empty ``SCENE.files/``); GrabCut's working size is bounded."""
from __future__ import annotations

import os

import numpy as np
import pytest

import puppet
from puppet.output import OutputError
from tests.cli.outputs_helpers import Mount, bounded, snapshot  # noqa: F401  (bounded: the fixture)
from tests.conftest import bar_image, bar_scene, write_rgba

pytestmark = pytest.mark.usefixtures("bounded")


@pytest.mark.gl
def test_save_into_a_symlinked_folder_loads_from_both_paths(tmp_path, make_scene):
    (tmp_path / "proj" / "imgs").mkdir(parents=True)
    (tmp_path / "proj" / "scenes").mkdir()
    (tmp_path / "other").mkdir()
    os.symlink(tmp_path / "proj" / "scenes", tmp_path / "other" / "link")
    write_rgba(tmp_path / "proj" / "imgs" / "bar.png", bar_image())
    s = puppet.new_scene(str(tmp_path / "proj" / "imgs" / "bar.png"))
    s.set_mask_pixels("layer1", np.ones((40, 120), bool))  # painted: written into SCENE.files/
    ref = s.render()
    s.save(str(tmp_path / "other" / "link" / "s.json"))
    for p in (tmp_path / "other" / "link" / "s.json", tmp_path / "proj" / "scenes" / "s.json"):
        t = puppet.load_scene(str(p))
        np.testing.assert_array_equal(t.render(), ref)
        t.close()
    s.close()


def test_save_with_painted_pixels_on_a_full_disk_leaves_nothing(tmp_path):
    disk = Mount(tmp_path / "disk", size="256k")
    try:
        write_rgba(tmp_path / "disk" / "bar.png", bar_image())
        doc = bar_scene()
        (tmp_path / "disk" / "scene.json").write_text(__import__("json").dumps(doc))
        s = puppet.load_scene(str(tmp_path / "disk" / "scene.json"))
        rng = np.random.default_rng(1)
        s.set_mask_pixels("bar", rng.random((40, 120)) > 0.5)  # noise: a PNG that does not compress away
        disk.fill()
        before = snapshot(tmp_path / "disk")
        with pytest.raises(OutputError):
            s.save(str(tmp_path / "disk" / "scene.json"))
        assert snapshot(tmp_path / "disk") == before  # no scene.files/, no temporary
        s.close()
    finally:
        disk.close()


def test_grabcut_downscaled_then_refined_matches_the_full_cut(monkeypatch):
    import puppet.imaging.grabcut as gc
    from puppet.imaging.masks import grabcut_mask

    rng = np.random.default_rng(0)
    img = np.full((300, 400, 4), 230, np.uint8)
    img[..., :3] += rng.integers(0, 20, (300, 400, 3), dtype=np.uint8)
    yy, xx = np.ogrid[:300, :400]
    blob = (yy - 150) ** 2 / 80 ** 2 + (xx - 200) ** 2 / 110 ** 2 < 1
    img[blob, :3] = rng.integers(0, 60, (int(blob.sum()), 3), dtype=np.uint8)
    full = grabcut_mask(img, [60, 40, 280, 220])
    assert (full ^ blob).sum() < 0.01 * blob.sum()
    calls = []
    real = gc._cut
    monkeypatch.setattr(gc, "_cut", lambda bgr, rect, it: calls.append(bgr.shape) or real(bgr, rect, it))
    monkeypatch.setattr(gc, "WORK_PIXELS", 20_000)
    small = grabcut_mask(img, [60, 40, 280, 220])
    assert calls and calls[0][0] * calls[0][1] <= 20_000  # the cut ran on the downscaled picture
    assert (small ^ blob).sum() < 0.01 * blob.sum()  # refined at full size: the edge is where it was


@pytest.mark.parametrize("rect", [[0, 0, 400, 300], [-50, -50, 1000, 1000], [0, 0, 399, 300], [1, 1, 398, 298]])
def test_grabcut_rectangle_covering_the_picture(rect):
    from puppet.imaging.masks import grabcut_mask

    img = np.full((300, 400, 4), 230, np.uint8)
    img[80:220, 120:280, :3] = 30
    m = grabcut_mask(img, rect)
    assert m.shape == (300, 400) and m[150, 200] and not m[5, 5]
