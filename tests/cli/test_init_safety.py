"""Issue 30 (what an import writes) through the real CLI, a subprocess each (bounded in
time and address space): the layers folder or a layer file as a symlink, a user's files in
the layers folder, a file the scene reads, ``--update`` after a rename or over unrelated
art (the backup, the notes), a write that fails after the PNGs (nothing left, old files
intact), layers too small to mesh, a scene file that is a symlink into another folder,
layer names too long for a file name. Every refusal: exit 2, one stderr line, no
traceback, every file byte-identical, nothing left behind."""
from __future__ import annotations

import io
import json
import os
import resource
import signal
import subprocess
import sys
import zipfile
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest
from PIL import Image

from tests.artfiles import CANVAS, parts
from tests.cli.outputs_helpers import Mount, one_error_line
from tests.conftest import ROOT
from tests.fstree import snapshot

MEMORY = 3 << 30  # the child's address space


def cli(*args, cwd, timeout=60, fsize=None) -> subprocess.CompletedProcess:
    """``python -m puppet ARGS`` in ``cwd``, under a memory cap (and a file size cap)."""
    def limits():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))
        if fsize is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the cap fails with EFBIG
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "puppet", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=str(cwd), preexec_fn=limits)


def ok(r) -> list[str]:
    """Exit 0, no traceback; the stderr notes."""
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    return r.stderr.splitlines()


def png(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG")
    return buf.getvalue()


def write_ora(path, layers, canvas=CANVAS) -> None:
    """An OpenRaster file of ``layers``: (name, rgba, (x, y)) back to front; a name with
    ``/`` is put in nested groups."""
    xml = ['<?xml version="1.0" encoding="UTF-8"?>', f'<image w="{canvas[0]}" h="{canvas[1]}">', "<stack>"]
    members = {}
    for k, (name, rgba, (x, y)) in enumerate(reversed(layers)):
        *groups, leaf = name.split("/")
        members[f"data/{k}.png"] = png(rgba)
        xml += [f"<stack name={quoteattr(g)}>" for g in groups]
        xml.append(f'<layer name={quoteattr(leaf)} src="data/{k}.png" x="{x}" y="{y}" visibility="visible"/>')
        xml += ["</stack>"] * len(groups)
    xml += ["</stack>", "</image>"]
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
        z.writestr("stack.xml", "\n".join(xml))
        for k, v in members.items():
            z.writestr(k, v, compress_type=zipfile.ZIP_DEFLATED)


def character(rename: dict | None = None, drop=()) -> list:
    """The seven-part character (tests/artfiles.py) as ORA layers; ``rename``: old -> new names."""
    rename = rename or {}
    out = []
    for name, group, rgba, off in parts():
        full = f"{group}/{name}" if group else name
        if full not in drop:
            out.append((rename.get(full, full), rgba, off))
    return out


def blob(w, h, colour=(200, 60, 40)) -> np.ndarray:
    a = np.zeros((h, w, 4), np.uint8)
    a[..., :3] = colour
    a[..., 3] = 255
    return a


@pytest.fixture
def art(tmp_path):
    path = tmp_path / "char.ora"
    write_ora(path, character())
    return path


def rigged(tmp_path, art) -> dict:
    """Import the character with pins, add a pose and keys over every pin; the scene JSON."""
    ok(cli("init", art, "-o", "char.json", "--pins", "auto", cwd=tmp_path))
    doc = json.loads((tmp_path / "char.json").read_text())
    pins = {p["name"]: p["at"] for p in doc["pins"]}
    doc["poses"] = {"up": {n: [at[0], at[1] - 1] for n, at in pins.items()}}
    doc["animation"] = {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "up"}]}
    (tmp_path / "char.json").write_text(json.dumps(doc))
    return doc


# -- 1. writes outside the output ---------------------------------------------------------
def test_a_symlinked_layers_folder_is_refused_and_its_target_untouched(tmp_path, art):
    other = tmp_path / "other"
    other.mkdir()
    (other / "body.png").write_bytes(b"the user's own body.png")
    os.symlink(other, tmp_path / "char-layers")
    before = snapshot(str(tmp_path))
    line = one_error_line(cli("init", art, "-o", "char.json", cwd=tmp_path))
    assert "char-layers" in line and "symbolic link" in line
    assert snapshot(str(tmp_path)) == before
    line = one_error_line(cli("init", art, "-o", "char.json", "--force", cwd=tmp_path))  # never through a link
    assert snapshot(str(tmp_path)) == before


# -- 2. a user's files overwritten -----------------------------------------------------
def test_a_users_file_in_the_layers_folder_needs_force(tmp_path, art):
    (tmp_path / "char-layers").mkdir()
    (tmp_path / "char-layers" / "body.png").write_bytes(b"mine")
    (tmp_path / "char-layers" / "notes.txt").write_bytes(b"also mine")
    before = snapshot(str(tmp_path))
    line = one_error_line(cli("init", art, "-o", "char.json", cwd=tmp_path))
    assert "char-layers/body.png" in line and "--force" in line
    assert snapshot(str(tmp_path)) == before
    ok(cli("init", art, "-o", "char.json", "--force", cwd=tmp_path))
    assert (tmp_path / "char-layers" / "body.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "char-layers" / "notes.txt").read_bytes() == b"also mine"  # not in the way: kept


def test_a_file_edited_since_the_import_needs_force(tmp_path, art):
    ok(cli("init", art, "-o", "char.json", cwd=tmp_path))
    ok(cli("init", art, "-o", "char.json", cwd=tmp_path))  # its own files: replaced without a word
    (tmp_path / "char-layers" / "head.png").write_bytes(b"painted over")
    before = snapshot(str(tmp_path))
    line = one_error_line(cli("init", art, "-o", "char.json", "--update", cwd=tmp_path))
    assert "head.png" in line and "changed since" in line and "--force" in line
    assert snapshot(str(tmp_path)) == before


@pytest.mark.slow  # four runs of the CLI
def test_update_never_replaces_a_file_the_scene_reads(tmp_path, art):
    ok(cli("init", art, "-o", "char.json", cwd=tmp_path))
    h, w = parts()[3][2].shape[:2]  # the body's size
    stiff = blob(w, h, (128, 128, 128))
    (tmp_path / "char-layers" / "tail.png").write_bytes(png(stiff))
    doc = json.loads((tmp_path / "char.json").read_text())
    body = next(L for L in doc["layers"] if L["name"] == "body")
    body["stiffness"] = {"file": "char-layers/tail.png"}
    (tmp_path / "char.json").write_text(json.dumps(doc))
    ok(cli("check", "char.json", cwd=tmp_path))
    before = (tmp_path / "char-layers" / "tail.png").read_bytes()
    write_ora(art, character() + [("tail", blob(30, 20), (10, 10))])  # the art gains a layer of that name
    notes = ok(cli("init", art, "-o", "char.json", "--update", cwd=tmp_path))
    assert (tmp_path / "char-layers" / "tail.png").read_bytes() == before
    new = json.loads((tmp_path / "char.json").read_text())
    tail = next(L for L in new["layers"] if L["name"] == "tail")
    assert tail["image"] != "char-layers/tail.png" and tail["image"].startswith("char-layers/tail")
    assert any("kept in char.json.bak" in n for n in notes)
    ok(cli("check", "char.json", cwd=tmp_path))


def test_a_symlink_in_the_layers_folder_is_refused_then_replaced_not_followed(tmp_path, art):
    outside = tmp_path / "outside.png"
    outside.write_bytes(b"the linked file")
    (tmp_path / "char-layers").mkdir()
    os.symlink(outside, tmp_path / "char-layers" / "head.png")
    before = snapshot(str(tmp_path))
    line = one_error_line(cli("init", art, "-o", "char.json", cwd=tmp_path))
    assert "head.png" in line and "symbolic link" in line and "--force" in line
    assert snapshot(str(tmp_path)) == before
    ok(cli("init", art, "-o", "char.json", "--force", cwd=tmp_path))
    assert outside.read_bytes() == b"the linked file"
    assert not os.path.islink(tmp_path / "char-layers" / "head.png")


# -- 3. the rig lost without a copy ------------------------------------------------------
def test_update_after_a_rename_keeps_the_rig_by_content_and_a_backup(tmp_path, art):
    doc = rigged(tmp_path, art)
    old_bytes = (tmp_path / "char.json").read_bytes()
    on_arm = sorted(p["name"] for p in doc["pins"] if p["layer"] == "arm_front")
    on_legs = sorted(p["name"] for p in doc["pins"] if p["layer"].startswith("legs/"))
    assert on_arm and on_legs
    write_ora(art, character(rename={"arm_front": "front arm", "legs/left": "pants/left",
                                     "legs/right": "pants/right"}))
    r = cli("init", art, "-o", "char.json", "--update", cwd=tmp_path)
    text = "\n".join(ok(r))
    assert "layer 'arm_front' renamed to 'front arm' (matched by content)" in text
    assert "layer 'legs/left' renamed to 'pants/left' (matched by content)" in text
    assert "layer 'legs/right' renamed to 'pants/right' (matched by content)" in text
    assert "no longer in the art" not in text and "7 replaced, 0 added, 0 removed" in r.stdout
    new = json.loads((tmp_path / "char.json").read_text())
    assert len(new["pins"]) == len(doc["pins"])
    assert sorted(p["name"] for p in new["pins"] if p["layer"] == "front arm") == on_arm
    assert len(new["poses"]["up"]) == len(doc["poses"]["up"])
    assert (tmp_path / "char.json.bak").read_bytes() == old_bytes
    ok(cli("check", "char.json", cwd=tmp_path))


def test_update_over_unrelated_art_says_what_it_dropped_and_keeps_a_copy(tmp_path, art):
    doc = rigged(tmp_path, art)
    old_bytes = (tmp_path / "char.json").read_bytes()
    (tmp_path / "char.json.bak").write_bytes(b"an older backup")
    write_ora(art, [("sun", blob(80, 80, (250, 200, 0)), (20, 20)), ("sea", blob(400, 100, (0, 80, 200)), (10, 480))])
    notes = ok(cli("init", art, "-o", "char.json", "--update", cwd=tmp_path))
    text = "\n".join(notes)
    assert f"{len(doc['pins'])} pin(s) removed with their layers" in text
    assert "pose target(s) and key entries of removed pins dropped" in text
    bak = [n for n in os.listdir(tmp_path) if n.startswith("char.json.") and n.endswith(".bak") and n != "char.json.bak"]
    assert len(bak) == 1 and (tmp_path / bak[0]).read_bytes() == old_bytes
    assert f"kept in {bak[0]}" in text
    assert (tmp_path / "char.json.bak").read_bytes() == b"an older backup"


# -- 4. half-written output ------------------------------------------------------------
def test_a_write_that_fails_after_the_pngs_leaves_nothing(tmp_path):
    art = tmp_path / "many.ora"
    many(art)
    before = snapshot(str(tmp_path))
    r = cli("init", art, "-o", "s.json", cwd=tmp_path, fsize=4096)  # each PNG fits; the scene does not
    line = one_error_line(r)
    assert "cannot write" in line
    assert snapshot(str(tmp_path)) == before


def many(path, n=60, colour=(100, 50)) -> None:
    """``n`` small one-colour layers (a PNG of about 100 bytes each, a scene of some kB)."""
    write_ora(path, [(f"part{i:02d}", blob(12, 12, (i * 3, *colour)), (5 + 14 * (i % 20), 5 + 14 * (i // 20)))
                     for i in range(n)])


def test_a_failed_update_leaves_the_old_files_intact(tmp_path):
    art = tmp_path / "many.ora"
    many(art)
    ok(cli("init", art, "-o", "s.json", cwd=tmp_path))
    many(art, 65, colour=(20, 200))  # every layer's pixels changed, five more
    before = snapshot(str(tmp_path))
    one_error_line(cli("init", art, "-o", "s.json", "--update", cwd=tmp_path, fsize=4096))
    assert snapshot(str(tmp_path)) == before


def test_a_full_disk_after_the_pngs_leaves_nothing(tmp_path):
    disk = tmp_path / "disk"
    m = Mount(disk, size="1m")
    try:
        art = disk / "many.ora"
        many(art)
        m.fill()
        os.remove(disk / "filler")
        st = os.statvfs(disk)
        with open(disk / "filler", "wb") as f:  # room for the 60 PNGs (a page each) and one page more
            f.write(b"\0" * ((st.f_bavail - 61) * st.f_frsize))
        before = snapshot(str(disk))
        assert "No space left" in one_error_line(cli("init", art, "-o", "s.json", cwd=disk))
        assert snapshot(str(disk)) == before
    finally:
        m.close()


# -- 7. silently wrong ------------------------------------------------------------------
def test_layers_of_a_pixel_or_two_are_kept_and_render_every_pixel(tmp_path):
    """A layer of one or two pixels meshes (its outline runs round whole pixels, also at
    the layer image's edge), so it is kept and drawn (issue 32; before, such layers were
    left out, and before that the scene failed to render)."""
    art = tmp_path / "a.ora"
    write_ora(art, [("big", blob(40, 40), (10, 10)), ("dot", blob(1, 1, (20, 200, 30)), (60, 60)),
                    ("pair", blob(2, 1, (30, 40, 220)), (70, 70)), ("line", blob(2, 30), (80, 10))], canvas=(100, 100))
    notes = ok(cli("init", art, "-o", "s.json", cwd=tmp_path))
    assert not any("too small to mesh" in n for n in notes)
    doc = json.loads((tmp_path / "s.json").read_text())
    assert [L["name"] for L in doc["layers"]] == ["big", "dot", "pair", "line"]
    ok(cli("render", "s.json", "-o", "out.png", cwd=tmp_path))
    from PIL import Image

    out = np.asarray(Image.open(tmp_path / "out.png").convert("RGBA")).astype(int)
    assert (out[60, 60] == (20, 200, 30, 255)).all() and (out[70, 70:72] == (30, 40, 220, 255)).all()
    assert (out[10:50, 10:50, 3] == 255).all() and (out[10:40, 80:82, 3] == 255).all()  # last rows and columns too
    assert out[50, 30, 3] == 0 and out[30, 50, 3] == 0 and out[59, 60, 3] == 0 and out[60, 61, 3] == 0


@pytest.mark.parametrize("kind", ["art", "picture"])
def test_init_through_a_symlinked_scene_loads_by_both_paths(tmp_path, kind):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    if kind == "art":
        src = tmp_path / "a" / "char.ora"
        write_ora(src, character())
    else:
        src = tmp_path / "a" / "head.png"
        src.write_bytes(png(parts()[5][2]))
    os.symlink("../b/real.json", tmp_path / "a" / "link.json")
    ok(cli("init", src, "-o", "a/link.json", cwd=tmp_path))
    ok(cli("check", "a/link.json", cwd=tmp_path))
    ok(cli("check", "b/real.json", cwd=tmp_path))


# -- 8. valid names too long for a file ---------------------------------------------------
def test_long_layer_names_import_with_short_stable_file_names(tmp_path):
    arm, head = parts()[0][2], parts()[5][2]
    layers = [("a" * 255, arm, (10, 200)),                      # Photoshop's longest name
              ("a" * 254 + "b", arm, (200, 200)),               # the same beginning
              ("é" * 5000, head, (100, 20)),                    # a long ORA name
              ("/".join(f"g{i}" for i in range(200)) + "/leaf", head, (100, 300))]  # 200 groups deep
    art = tmp_path / "long.ora"
    write_ora(art, layers, canvas=(420, 600))
    ok(cli("init", art, "-o", "s.json", cwd=tmp_path))
    doc = json.loads((tmp_path / "s.json").read_text())
    files = [L["image"] for L in doc["layers"]]
    assert len(doc["layers"]) == 4 and len({f.lower() for f in files}) == 4
    assert all(len(os.path.basename(f).encode()) <= 100 for f in files)
    ok(cli("init", art, "-o", "s.json", "--update", cwd=tmp_path))
    assert [L["image"] for L in json.loads((tmp_path / "s.json").read_text())["layers"]] == files  # stable
    ok(cli("check", "s.json", cwd=tmp_path))


# -- 4. the app's open path --------------------------------------------------------------
def test_the_app_on_art_it_refuses_leaves_nothing(tmp_path):
    art = tmp_path / "dot.ora"
    write_ora(art, [("dot", np.zeros((1, 1, 4), np.uint8), (60, 60))], canvas=(100, 100))  # no pixel drawn
    before = snapshot(str(tmp_path))
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = subprocess.run([sys.executable, "-m", "puppet", "app", str(art)], capture_output=True, text=True,
                       timeout=60, env=dict(env, PYTHONPATH=ROOT), cwd=str(tmp_path),
                       preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY)))
    assert "nothing to import" in one_error_line(r)  # the art is imported before the display is asked for
    assert snapshot(str(tmp_path)) == before  # no dot.json, no dot-layers/


@pytest.mark.slow  # three runs of the CLI on the seven-part character
def test_an_import_from_before_manifests_owns_its_images_a_hand_made_scene_none(tmp_path, art):
    ok(cli("init", art, "-o", "char.json", cwd=tmp_path))
    os.remove(tmp_path / "char-layers" / ".puppet-import.json")  # as an import before manifests left it
    ok(cli("init", art, "-o", "char.json", cwd=tmp_path))  # names its art (app.art): its images are its own
    os.remove(tmp_path / "char-layers" / ".puppet-import.json")
    doc = json.loads((tmp_path / "char.json").read_text())
    del doc["app"]  # a scene written by hand over the same images
    (tmp_path / "char.json").write_text(json.dumps(doc))
    before = snapshot(str(tmp_path))
    assert "--force" in one_error_line(cli("init", art, "-o", "char.json", cwd=tmp_path))
    assert snapshot(str(tmp_path)) == before


# -- the art file is a file the scene reads ----------------------------------------------
def test_the_art_file_is_never_overwritten_by_a_save(tmp_path, art):
    ok(cli("init", art, "-o", "char.json", cwd=tmp_path))
    before = snapshot(str(tmp_path))
    script = ("import puppet, sys\n"
              "from puppet.errors import SceneError\n"
              "try:\n    puppet.load_scene('char.json').save(sys.argv[1])\n"
              "except SceneError as e:\n    print(e)\n")
    r = subprocess.run([sys.executable, "-c", script, str(art)], capture_output=True, text=True, timeout=60,
                       cwd=str(tmp_path), env=dict(os.environ, PYTHONPATH=ROOT))
    assert "it is a file the scene reads" in r.stdout and "app.art" in r.stdout, r.stdout + r.stderr
    assert snapshot(str(tmp_path)) == before


# -- a stop during an import: the whole import or nothing ---------------------------------
STOP = """
import os, signal, sys
import puppet.cli as cli
import puppet.output as output
import puppet.scene.make.art as art
when = sys.argv[2]
def stop():
    os.kill(os.getpid(), signal.SIGTERM)
if when == "staging":  # while the PNGs are written to the staging folder
    real_pngs = art._write_pngs
    def _write_pngs(*a, **k):
        stop()
        return real_pngs(*a, **k)
    art._write_pngs = _write_pngs
else:  # while the PNGs and the scene are renamed into place (signals held)
    real_commit_all = output.commit_all
    def commit_all(staged):
        stop()
        return real_commit_all(staged)
    output.commit_all = commit_all
sys.argv = ["puppet", "init", sys.argv[1], "-o", "char.json"]
sys.exit(cli.main())
"""


@pytest.mark.parametrize("when", ["staging", "commit"])
def test_a_stop_during_an_import_leaves_the_whole_import_or_nothing(tmp_path, art, when):
    before = snapshot(str(tmp_path))
    r = subprocess.run([sys.executable, "-c", STOP, str(art), when], capture_output=True, text=True, timeout=60,
                       cwd=str(tmp_path), env=dict(os.environ, PYTHONPATH=ROOT))
    assert r.returncode == -signal.SIGTERM and r.stderr == "puppet: stopped by SIGTERM\n", r.stderr
    if when == "staging":
        assert snapshot(str(tmp_path)) == before
        return
    left = sorted(os.listdir(tmp_path))
    assert left == ["char-layers", "char.json", "char.ora"], left  # no staging folder, no temporary
    ok(cli("check", "char.json", cwd=tmp_path))  # the scene and every layer image it names are there
