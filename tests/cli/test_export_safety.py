"""Issue 30, the exporters' sinks, through the real CLI (a subprocess each, bounded in
time, and in memory where an export could hold too much): files beside the output whose
names puppet picks (Spine's atlas and page, a sprite sheet's atlas) are never written
through a link; an existing folder at a file output is refused, not filled with frames;
a Spine export too long to hold is refused up front; layer and scene names cannot break
the web player's page. Every refusal: exit 2, one stderr line, no traceback, every file
byte-identical and nothing left behind."""
from __future__ import annotations

import errno
import html
import json
import os
import re
import resource
import shutil
import subprocess
import sys
from html.parser import HTMLParser

import pytest

from puppet import output
from puppet.anim import sinks
from puppet.anim.export import animate_to
from puppet.api import load_scene
from puppet.errors import SceneError
from tests.cli.outputs_helpers import cli, make_bar, one_error_line, snapshot
from tests.conftest import ROOT
from tests.video.video_helpers import video_scene, write_folder_clip, write_scene

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def capped(*args, memory: int = 3 << 30, timeout: float = 60) -> subprocess.CompletedProcess:
    """``python -m puppet ARGS`` with at most ``memory`` bytes of address space."""
    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "puppet", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=ROOT, preexec_fn=cap)


@pytest.fixture
def bar(tmp_path):
    return make_bar(tmp_path / "s")


# -- side files: never through a link ------------------------------------------------
@pytest.mark.parametrize("out,side", [("o.spine.json", "o.spine.atlas"), ("o.spine.json", "o.spine.png"),
                                      ("o.json --format spine", "o.atlas"), ("o.png", "o.json")])
def test_a_side_file_that_is_a_link_is_refused(tmp_path, bar, out, side):
    other = tmp_path / "other"
    other.mkdir()
    (other / "victim").write_bytes(b"the user's own file\n")
    os.symlink(other / "victim", tmp_path / side)
    name, *more = out.split()
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", bar, "-o", tmp_path / name, *more, "--to", "0.2", timeout=60))
    assert f"{tmp_path / side}: cannot write: is a symbolic link" in line
    assert snapshot(tmp_path) == before
    assert os.path.islink(tmp_path / side)


def test_the_named_output_may_be_a_link_and_its_side_files_are_plain(tmp_path, bar):
    other = tmp_path / "other"
    other.mkdir()
    (other / "anim.spine.json").write_text("old")
    os.symlink(other / "anim.spine.json", tmp_path / "o.spine.json")
    r = cli("animate", bar, "-o", tmp_path / "o.spine.json", "--to", "0.2", timeout=60)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert os.path.islink(tmp_path / "o.spine.json")  # followed, as named: the link is kept
    assert json.loads((other / "anim.spine.json").read_text())["skeleton"]["spine"] == "4.2.0"
    for side in ("o.spine.atlas", "o.spine.png"):  # beside the name given, plain files
        assert os.path.isfile(tmp_path / side) and not os.path.islink(tmp_path / side)
    assert sorted(os.listdir(other)) == ["anim.spine.json"]


def test_a_later_atlas_page_that_is_a_link_is_refused_before_solving(tmp_path, monkeypatch, capsys):
    import puppet.anim.spine as spine
    from puppet.cli import main

    trex = os.path.join(ROOT, "assets", "scenes", "trex-layers.json")
    monkeypatch.setattr(spine, "PAGE_SIDE", 300)  # the T-rex's layers need more than one page
    (tmp_path / "victim").write_bytes(b"keep")
    os.symlink(tmp_path / "victim", tmp_path / "t.spine_2.png")
    before = snapshot(tmp_path)
    assert main(["animate", trex, "-o", str(tmp_path / "t.spine.json"), "--to", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "t.spine_2.png: cannot write: is a symbolic link" in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("fails", ["staging the atlas", "renaming the JSON"])
def test_the_output_and_its_side_files_are_committed_together(tmp_path, monkeypatch, fails):
    """A failure after the page is staged (the atlas hits a full disk) or after the side
    files are renamed (the JSON's rename fails) leaves none of the three files."""
    scene = load_scene(make_bar(tmp_path / "s", seconds=1.0))
    out = tmp_path / "o.spine.json"
    real_init, real_commit = output.Staged.__init__, output.Staged.commit

    def init(self, path, write, **kw):
        if fails == "staging the atlas" and path.endswith(".atlas"):
            raise output.OutputError(path, os.strerror(errno.ENOSPC))
        real_init(self, path, write, **kw)

    def commit(self):
        if fails == "renaming the JSON" and self.path == str(out):
            raise output.OutputError(self.path, os.strerror(errno.EIO))
        real_commit(self)
    monkeypatch.setattr(output.Staged, "__init__", init)
    monkeypatch.setattr(output.Staged, "commit", commit)
    before = snapshot(tmp_path)
    with pytest.raises(output.OutputError, match="No space left|Input/output error"):
        animate_to(scene, str(out))
    assert snapshot(tmp_path) == before  # no page, no atlas, no JSON, no temporary


# -- the output's kind against what is at the path -----------------------------------
@pytest.mark.parametrize("name", ["out.html", "out.glb", "out.spine.json", "out.gif", "out.png", "out.mp4",
                                  "out.webm", "out.apng", "out.json --format spine"])
def test_an_existing_folder_at_a_file_output_is_refused(tmp_path, bar, name):
    path, *more = name.split()
    (tmp_path / path).mkdir()
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", bar, "-o", tmp_path / path, *more, "--to", "0.2", timeout=60))
    assert line == f"puppet: error: {tmp_path / path}: cannot write: is a folder"
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("name", ["out.mp4", "out.webm"])
def test_puppet_video_refuses_an_existing_folder_at_a_video_output(tmp_path, name):
    write_folder_clip(tmp_path / "clip", n=2)
    scene = write_scene(tmp_path, video_scene("clip"))
    (tmp_path / name).mkdir()
    before = snapshot(tmp_path)
    line = one_error_line(cli("video", scene, "--pose", "wave", "-o", tmp_path / name, timeout=60))
    assert line == f"puppet: error: {tmp_path / name}: cannot write: is a folder"
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("name", ["out.gltf", "out.jpg", "out.json"])
def test_an_existing_folder_named_like_a_file_puppet_does_not_write_is_refused(tmp_path, bar, name):
    (tmp_path / name).mkdir()
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", bar, "-o", tmp_path / name, "--to", "0.2", timeout=60))
    assert line.startswith(f"puppet: error: -o '{tmp_path / name}': give a folder (ending in /) or a file")
    assert snapshot(tmp_path) == before  # not filled with frames


@pytest.mark.parametrize("name", ["frames", "frames.v2", "out.html/", "out.gltf/"])
def test_a_folder_without_a_known_ending_or_with_a_slash_gets_frames(tmp_path, bar, name):
    (tmp_path / name.rstrip("/")).mkdir()
    r = cli("animate", bar, "-o", f"{tmp_path / name.rstrip('/')}{'/' if name.endswith('/') else ''}",
            "--to", "0.2", timeout=60)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert sorted(os.listdir(tmp_path / name.rstrip("/"))) == ["frame_00000.png", "frame_00001.png",
                                                               "frame_00002.png"]


# -- exports that hold every frame ---------------------------------------------------
def test_a_spine_export_too_long_to_hold_is_refused_up_front_within_a_memory_cap(tmp_path):
    scene = make_bar(tmp_path / "s", seconds=4000)  # 308 vertices; 96001 frames at 24 fps
    before = snapshot(tmp_path)
    line = one_error_line(capped("animate", scene, "-o", tmp_path / "long.spine.json", "--fps", "24",
                                 memory=3 << 30, timeout=60))
    assert "4000 s at 24 fps (96001 frames) x 308 vertices in 1 layer would hold 6e+07 numbers" in line
    assert f"more than the {sinks.MAX_HELD:.2g} that a Spine file" in line and "use .html" in line
    assert snapshot(tmp_path) == before


def test_a_glb_with_too_many_vertices_for_its_frames_is_refused_through_the_api(tmp_path, monkeypatch):
    scene = load_scene(make_bar(tmp_path / "s", seconds=1.0))  # 11 frames x (308 vertices x 3 + 1 layer x 120)
    monkeypatch.setattr(sinks, "MAX_HELD", 5000)
    before = snapshot(tmp_path)
    with pytest.raises(SceneError, match=r"11 frames\) x 308 vertices in 1 layer would hold 1\.1e\+04 numbers "
                                         r"\(3 a vertex and 120 a layer each frame\), more than the 5e\+03"):
        animate_to(scene, str(tmp_path / "o.glb"))
    assert snapshot(tmp_path) == before


# -- the web player's page -----------------------------------------------------------
NAMES = ["<!--<script>", "</script><b>bold</b>", "\"'&amp;", "a\u2028b\u2029c", "{{meta}}", "</SCRIPT ", "]]>",
         "lone \ud800"]
SCENE_NAME = "{{meta}}<title>&.json"


class _Page(HTMLParser):
    """Elements, the title's text and each script's text, as an HTML parser reads them."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags, self.scripts, self.title, self._in = [], [], "", None

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs).get("id")))
        self._in = tag
        if tag == "script":
            self.scripts.append("")

    def handle_endtag(self, tag):
        self._in = None

    def handle_data(self, data):
        if self._in == "script":
            self.scripts[-1] += data
        elif self._in == "title":
            self.title += data


def named_scene(tmp_path, name: str | bytes = SCENE_NAME) -> str:
    """The bar scene with a layer for each of :data:`NAMES`, saved as ``name``."""
    scene = json.load(open(make_bar(tmp_path / "s", seconds=1.0)))
    scene["layers"] += [{"name": n, "image": "bar.png"} for n in NAMES]
    path = os.path.join(os.fsencode(tmp_path / "s"), os.fsencode(name))
    with open(path, "w") as f:
        json.dump(scene, f)
    return os.fsdecode(path)


@pytest.fixture
def named_page(tmp_path):
    path = named_scene(tmp_path)
    out = tmp_path / "named.html"
    r = cli("animate", path, "-o", out, timeout=60)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    return out


def test_names_cannot_end_or_escape_the_pages_scripts(named_page):
    text = named_page.read_text(encoding="utf-8")
    page = _Page()
    page.feed(text)
    scripts = [t for t in page.tags if t[0] == "script"]
    assert scripts == [("script", "puppet-meta"), ("script", "puppet-frames"), ("script", None)]
    for body in page.scripts:  # what would end a script element early or enter its escaped states
        assert not re.search(r"</?script|<!--", body, re.IGNORECASE), body[:200]
    meta = json.loads(page.scripts[0])
    assert [layer["name"] for layer in meta["layers"]] == ["bar", *NAMES]
    assert page.title == SCENE_NAME  # escaped text, not a field filled again
    assert text.count("<title>") == 1 and html.escape(SCENE_NAME) in text


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium: install Debian's chromium package")
def test_the_player_starts_in_a_browser_whatever_the_names(named_page):
    dom = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                          "--enable-unsafe-swiftshader", "--virtual-time-budget=30000", "--dump-dom",
                          f"file://{named_page}#t=0"], capture_output=True, text=True, timeout=180).stdout
    # paused on frame 0 (#t=0), the page is idle once ready, so a loaded machine's budget is cheap:
    # 8 s of virtual time ran out in CI with the textures still loading
    body = re.search(r"<body[^>]*>", dom)
    assert body and 'data-ready="1"' in body.group(0), dom[-2000:]
    assert f"<title>{html.escape(SCENE_NAME, quote=False)}</title>" in dom


@pytest.mark.parametrize("out", ["o.html", "o.spine.json"])
def test_names_that_are_not_utf8_export(tmp_path, out):
    path = named_scene(tmp_path, b"bytes \xff.json")  # a file name that is not UTF-8, a lone surrogate layer
    r = cli("animate", path, "-o", tmp_path / out, timeout=60)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    if out == "o.html":
        page = _Page()
        page.feed((tmp_path / out).read_text(encoding="utf-8"))
        assert page.title == "bytes \ufffd.json"
    else:
        regions = [ln for ln in (tmp_path / "o.spine.atlas").read_text(encoding="utf-8").split("\n")
                   if ln and not ln.startswith("\t") and not ln.endswith(".png")]
        assert len(regions) == 1 + len(NAMES) and "lone _" in regions
