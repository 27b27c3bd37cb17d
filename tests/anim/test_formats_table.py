"""The one table of output formats: lookup by path and by --format, and every consumer
(CLI help and choices, the Export dialog, batch jobs) reading it."""
from __future__ import annotations

import pytest

from puppet.anim import formats
from puppet.errors import SceneError


def test_kinds_and_suffixes_are_unique():
    kinds = [f.kind for f in formats.FORMATS]
    assert len(set(kinds)) == len(kinds) and set(formats.BY_KIND) == set(kinds)
    assert len(set(formats.suffixes())) == len(formats.FORMATS)


@pytest.mark.parametrize("path,kind", [("a.mp4", "mp4"), ("A.GIF", "gif"), ("a.png", "sheet"), ("d/", "dir"),
                                       ("a.html", "html"), ("a.spine.json", "spine"), ("a.glb", "glb"),
                                       ("a.webm", "webm"), ("a.apng", "apng")])
def test_the_ending_picks_the_format(path, kind):
    assert formats.find(path).kind == kind


def test_plain_json_needs_format_spine():
    with pytest.raises(SceneError, match="--format spine"):
        formats.find("a.json")
    assert formats.find("a.json", "spine").kind == "spine"
    assert formats.spine_side("out/a.json") == ["out/a.atlas", "out/a.png"]
    assert formats.spine_side("a.spine.json") == ["a.spine.atlas", "a.spine.png"]


@pytest.mark.parametrize("path,kind", [("a.mp4", "spine"), ("a.html", "glb"), ("d/", "mp4"), ("a.gif", "dir"),
                                       ("a.mp4", "nope")])
def test_format_must_fit_the_path(path, kind):
    with pytest.raises(SceneError, match="--format"):
        formats.find(path, kind)


def test_options_a_format_cannot_honour_are_refused():
    formats.check_options(formats.BY_KIND["mp4"], size=(10, 10), wireframe=True, background=(0, 0, 0, 255))
    formats.check_options(formats.BY_KIND["html"], size=(10, 10), background="transparent")
    with pytest.raises(SceneError, match="^--wireframe"):
        formats.check_options(formats.BY_KIND["html"], wireframe=True)
    for kind in ("spine", "glb"):
        with pytest.raises(SceneError, match="^--size"):
            formats.check_options(formats.BY_KIND[kind], size=(10, 10))


def test_consumers_read_the_table():
    from puppet.batch import jobs
    from puppet.cli import build_parser

    sub = build_parser()._subparsers._group_actions[0].choices["animate"]
    text = sub.format_help()
    fmt = next(a for a in sub._actions if a.dest == "format")
    assert tuple(fmt.choices) == tuple(formats.BY_KIND)
    joined = " ".join(text.split())
    for f in formats.FORMATS:
        assert (f.suffix if not f.folder else "folder/") in joined
    assert set(jobs.ANIM_EXTS) == {".gif", ".mp4", ".webm", ".apng", ".html", ".glb"}  # one file each
    jobs._kind_ext("animate", "x.html", "jobs.json", "[0]")
    for bad in ("x.png", "x.spine.json"):
        with pytest.raises(SceneError, match="an animation goes to"):
            jobs._kind_ext("animate", bad, "jobs.json", "[0]")


def test_export_dialog_lists_every_format():
    dialog = pytest.importorskip("puppet.app.ui.export_dialog")
    for f in formats.FORMATS:
        assert (f.suffix if not f.folder else "folder/") in dialog.FORMATS
