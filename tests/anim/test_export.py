"""Animation export end to end (real GL, real encoders): the streamed GIF shows the same
frames as the PNG folder, whether its palette sample is kept or drawn again."""
from __future__ import annotations

import os

import numpy as np
import pytest
from PIL import Image

from puppet.anim import export
from puppet.cli import main

pytestmark = pytest.mark.gl


def _gif_frames(path):
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append((np.array(im.convert("RGB")).astype(int), im.info["duration"]))
    return out


def test_gif_matches_the_png_frames(bar, tmp_path, monkeypatch):
    assert main(["animate", bar, "-o", str(tmp_path / "f") + "/"]) == 0
    pngs = [np.array(Image.open(tmp_path / "f" / n)) for n in sorted(os.listdir(tmp_path / "f"))]
    assert main(["animate", bar, "-o", str(tmp_path / "a.gif")]) == 0
    gif = _gif_frames(tmp_path / "a.gif")
    assert len(gif) == len(pngs) == 11 and sum(ms for _, ms in gif) == 1100
    for (rgb, _), rgba in zip(gif, pngs):
        want = export.flatten(rgba).astype(int)
        assert np.abs(rgb - want).mean() < 1.5 and np.abs(rgb - want).max() <= 64
    monkeypatch.setattr(export, "GIF_SAMPLE_CACHE", 0)  # the sample frames are drawn again
    assert main(["animate", bar, "-o", str(tmp_path / "b.gif")]) == 0
    assert (tmp_path / "a.gif").read_bytes() == (tmp_path / "b.gif").read_bytes()


def test_frames_are_drawn_lazily(bar, monkeypatch, tmp_path):
    """Frame i is drawn only after frames 0..i-1 went to disk (a frame folder shows it)."""
    import puppet

    scene = puppet.load_scene(bar)
    drawn, on_disk = [], []
    real = type(scene).render

    def render(self, *a, **k):
        drawn.append(k.get("time"))
        tmp = [n for n in os.listdir(tmp_path) if n.endswith(".tmp")]
        on_disk.append(len(os.listdir(tmp_path / tmp[0])) if tmp else -1)
        return real(self, *a, **k)

    monkeypatch.setattr(type(scene), "render", render)
    assert export.animate_to(scene, str(tmp_path / "frames") + "/") == 11
    assert drawn == pytest.approx([i / 10 for i in range(11)])
    assert on_disk == list(range(11))
