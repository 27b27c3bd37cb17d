"""Attack campaign on the surfaces of issue 30: layered art in (``puppet init`` of PSD, PSB,
ORA and KRA, ``--pins auto --links auto``, ``--update``, ``--force``; the app's open path),
animation out (``puppet animate`` to HTML, Spine, glTF...) and the editing API. Not
collected by pytest: run it::

    .venv/bin/python tests/safety/campaign_layered.py [-k WORD] [-j 2] [--timeout 60] [-v]

Each case runs in its own temporary folder (``in/`` inputs, ``out/`` outputs, ``outside/``
files nobody names, ``tmp/`` the run's $TMPDIR), as a subprocess under a timeout and an
address-space cap (RLIMIT_AS, :data:`MEMORY_CAP`): the real CLI (``python -m puppet ...``),
a short API script, or :func:`puppet.app.model.opening.preload` (what ``puppet app FILE``
does before any window opens; no GL). Every file, link, FIFO and folder is recorded
before and after (:func:`tests.fstree.snapshot`: nothing is read through a link), and each
case is judged:

- traceback: ``Traceback`` on stderr, or an exit status other than 0 and 2 (130 or the
  signal's own for a case that sends one) that is not a memory blow-up;
- hang: the timeout expired;
- memory: ``MemoryError`` (or another allocation failure) on stderr, or killed;
- messy: exit 2 without exactly one stderr line, ``puppet: error: ...``; or a Python
  warning on stderr at any exit status (section 9's noise);
- outside: anything new or changed that is not an output the case names, anything under
  ``outside/`` or ``tmp/`` changed (a write through a link), or anything at all left
  behind or changed by a run that failed;
- modified: a file that existed before (an input, or a user's own file placed among the
  outputs, e.g. ``out/S-layers/body.png``) changed or replaced, without ``--force``;
- wrong: a case-specific check: a scene ``init`` wrote that ``render`` refuses, a raw
  ``<!--`` in the web player's script, a folder at ``out.html`` filled with frames, an
  ``--update`` that drops rig without a copy of the old scene, an ORA entity expanded,
  a valid file refused, a bad API argument accepted.

Cases carry the issue section they test (1-9, or ``held``: what the issue says held).
Prints one line per bad case, then counts per category and per section, and one summary
line (``0 tracebacks, 0 hangs, ...`` when all is well). Exit status 1 when a case is bad.
Root is needed for the full-disk and read-only cases (a tmpfs is mounted in the case folder).
"""
from __future__ import annotations

import argparse
import fnmatch
import io
import json
import os
import random
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zipfile
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)
from tests import artfiles  # noqa: E402
from tests.fstree import snapshot  # noqa: E402
from tests.imaging.test_layered_zip import lzf_compress, tile_file  # noqa: E402
from tests.safety.campaign_files import fifo, link, unmount_under, write  # noqa: E402
from tests.safety.child import case_command, run_child  # noqa: E402

MEMORY_CAP = 4 << 30  # bytes of address space per case (the machine has 23 GB and 2 cores)
PY = sys.executable
CATEGORIES = ("traceback", "hang", "memory", "messy", "outside", "modified", "wrong")
FORMATS = ("psd", "psb", "ora", "kra")
MEMORY_WORDS = ("MemoryError", "Unable to allocate", "Cannot allocate memory", "bad_alloc", "Insufficient memory",
                "out of memory")


@dataclass
class Case:
    name: str
    section: str  # the section (1-9) or "held"
    argv: list[str] | None = None  # CLI arguments; "{d}" is the case folder
    script: str | None = None  # or a Python body run by SCRIPT with D = the case folder
    setup: list = field(default_factory=list)  # f(d) run after the template is copied
    outputs: tuple[str, ...] = ()  # fnmatch patterns (relative to d) the case may create or change
    protect: tuple[str, ...] = ()  # user files among the outputs: must stay unless --force
    checks: list = field(default_factory=list)  # f(d, res, before, after) -> a complaint or None
    renders: tuple[str, ...] = ()  # scenes (relative) that `puppet render` must take after a success
    expect_ok: bool = False  # a valid file: a refusal is "wrong"
    signal_after: tuple | None = None  # (signal, seconds) sent to the process group
    timeout: float | None = None
    memory_cap: int = MEMORY_CAP  # bytes of address space


# -- the template every case starts from ---------------------------------------------------------------
def renamed(items, mapping):
    """``items`` with layer/group names replaced by ``mapping``."""
    return [(mapping.get(n, n), mapping.get(g, g) if g else g, a, o) for n, g, a, o in items]


def solid(w, h, colour=(200, 60, 40, 255)):
    a = np.zeros((h, w, 4), np.uint8)
    a[...] = colour
    return a


def write_art(path: str, items, canvas=artfiles.CANVAS) -> None:
    """``items`` as the file's suffix says (PSD, PSB, ORA or KRA)."""
    ext = os.path.splitext(path)[1]
    if ext in (".psd", ".psb"):
        artfiles.write_psd_layers(path, items, canvas, version=2 if ext == ".psb" else 1)
    elif ext == ".ora":
        artfiles.write_ora_layers(path, items, canvas)
    else:
        kra_layers(path, [(n, g, a, o) for n, g, a, o in items], canvas)


def kra_layers(path, items, canvas=artfiles.CANVAS, *, attrs=None, files=None):
    """A KRA of ``items`` (name, group or None, rgba, offset) back to front; ``attrs``: extra
    or replaced attributes of every paint layer; ``files``: members instead of the tiles."""
    from xml.sax.saxutils import quoteattr

    members = {}

    def leaf(k, name, rgba, x, y):
        members[f"d/layers/l{k}"] = tile_file(rgba)
        a = dict(name=name, filename=f"l{k}", nodetype="paintlayer", visible="1", opacity="255", x=str(x),
                 y=str(y), compositeop="normal", colorspacename="RGBA")
        a.update(attrs or {})
        return "<layer " + " ".join(f"{k}={quoteattr(v)}" for k, v in a.items()) + "/>"
    xml = artfiles.tree_xml(items, lambda g: f'<layer name={quoteattr(g)} nodetype="grouplayer" visible="1" '
                            'opacity="255"><layers>', "</layers></layer>", leaf)
    kra_doc(path, "".join(xml), files if files is not None else members, canvas)


def kra_doc(path, layers_xml, members, canvas=artfiles.CANVAS, *, w=None, h=None):
    doc = (f'<?xml version="1.0"?><DOC><IMAGE name="d" width="{w or canvas[0]}" height="{h or canvas[1]}" '
           f'colorspacename="RGBA"><layers>{layers_xml}</layers></IMAGE></DOC>')
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("mimetype", "application/x-krita")
        z.writestr("maindoc.xml", doc)
        for k, v in members.items():
            z.writestr(k, v, compress_type=zipfile.ZIP_DEFLATED)


def ora_doc(path, stack_xml: bytes | str, members: dict, w=100, h=100, *, head=True):
    """An ORA whose stack.xml is ``stack_xml`` (wrapped in <image><stack> unless ``head`` is False)."""
    if head:
        stack_xml = (f'<?xml version="1.0" encoding="UTF-8"?><image version="0.0.3" w="{w}" h="{h}"><stack>'
                     f'{stack_xml}</stack></image>')
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
        z.writestr("stack.xml", stack_xml)
        for k, v in members.items():
            z.writestr(k, v, compress_type=zipfile.ZIP_DEFLATED)


def ora_layer(name, src="data/a.png", x=0, y=0, **more):
    from xml.sax.saxutils import quoteattr

    extra = "".join(f" {k.replace('_', '-')}={quoteattr(str(v))}" for k, v in more.items())
    return f"<layer name={quoteattr(name)} src={quoteattr(src)} x={quoteattr(str(x))} y={quoteattr(str(y))}{extra}/>"


def encrypt_member(path: str, name: str) -> None:
    """Set the 'encrypted' flag of member ``name`` (local and central headers), as a
    password-protected zip has it."""
    data = bytearray(open(path, "rb").read())
    enc = name.encode()
    for sig, flag_at, name_len_at, name_at in ((b"PK\x03\x04", 6, 26, 30), (b"PK\x01\x02", 8, 28, 46)):
        i = data.find(sig)
        while i >= 0:
            n = struct.unpack_from("<H", data, i + name_len_at)[0]
            if bytes(data[i + name_at:i + name_at + n]) == enc:
                struct.pack_into("<H", data, i + flag_at, struct.unpack_from("<H", data, i + flag_at)[0] | 1)
            i = data.find(sig, i + 4)
    open(path, "wb").write(bytes(data))


def build_template(t: str) -> dict:
    """The folders every case copies; returns facts the cases need (sizes of the written PNGs)."""
    for sub in ("in", "out", "outside", "tmp"):
        os.makedirs(os.path.join(t, sub))
    i = os.path.join(t, "in")
    items = artfiles.parts()
    for fmt in FORMATS:
        write_art(os.path.join(i, f"char.{fmt}"), items)
        write_art(os.path.join(i, f"renamed.{fmt}"), renamed(items, {"head": "face", "legs": "feet"}))
        write_art(os.path.join(i, f"other.{fmt}"),
                  [(f"shape{k}", None, a, (o[0] // 2 + 10, o[1] // 2)) for k, (_, _, a, o) in enumerate(items[:3])])
        write_art(os.path.join(i, f"plus.{fmt}"), items + [("stiff", None, solid(30, 30), (140, 240))])
        write_art(os.path.join(i, f"recolour.{fmt}"), artfiles.parts(recolour="head"))
    with open(os.path.join(t, "outside", "precious.txt"), "w") as f:
        f.write("not yours\n")
    os.makedirs(os.path.join(t, "outside", "dir"))
    with open(os.path.join(t, "outside", "dir", "body.png"), "wb") as f:
        f.write(artfiles.png_bytes(solid(5, 5)))
    # scenes made by init, at the depth of out/ (their paths and app.art stay right when copied there)
    env = dict(os.environ, PYTHONPATH=ROOT)
    for fmt in FORMATS:
        base = os.path.join(t, f"base_{fmt}")
        os.makedirs(base)
        subprocess.run([PY, "-m", "puppet", "init", os.path.join(i, f"char.{fmt}"), "-o", os.path.join(base, "S.json"),
                        "--pins", "auto", "--links", "auto"], check=True, capture_output=True, env=env)
    # the psd scene with a stiffness image of its own in S-layers/ (named as a future layer)
    st = os.path.join(t, "base_stiff")
    shutil.copytree(os.path.join(t, "base_psd"), st)
    doc = json.load(open(os.path.join(st, "S.json")))
    body = next(L for L in doc["layers"] if L["name"] == "body")
    bh, bw = artfiles.part("blueShirt1.png").shape[:2]
    with open(os.path.join(st, "S-layers", "stiff.png"), "wb") as f:
        f.write(artfiles.png_bytes(solid(bw, bh, (128, 128, 128, 255))))
    body["stiffness"] = {"file": "S-layers/stiff.png"}
    json.dump(doc, open(os.path.join(st, "S.json"), "w"))
    # an animated scene for the exports; one with hostile layer names; one 4000 s long
    subprocess.run([PY, "-m", "puppet", "init", os.path.join(i, "char.psd"), "-o", os.path.join(i, "anim.json"),
                    "--pins", "auto", "--links", "auto"], check=True, capture_output=True, env=env)
    doc = json.load(open(os.path.join(i, "anim.json")))
    pin = next(p for p in doc["pins"] if p["layer"] == "arm_front")
    doc["poses"] = {"wave": {pin["name"]: [pin["at"][0] + 25, pin["at"][1] - 30]}}
    doc["animation"] = {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1, "pose": "wave"}]}
    json.dump(doc, open(os.path.join(i, "anim.json"), "w"))
    evil = json.loads(json.dumps(doc).replace('"head', '"<!--<script>').replace('"body', '"</script>'))
    json.dump(evil, open(os.path.join(i, "evil.json"), "w"))
    long = dict(doc, animation={"fps": 20, "keys": [{"time": 0, "pose": "rest"}, {"time": 4000, "pose": "wave"}]})
    json.dump(long, open(os.path.join(i, "long.json"), "w"))
    starch = dict(doc, pins=doc["pins"] + [{"name": "st", "layer": "body", "kind": "starch", "radius": 1e-300,
                                            "at": [body["offset"][0] + bw / 2, body["offset"][1] + bh / 2]}])
    json.dump(starch, open(os.path.join(i, "starch.json"), "w"))
    sizes = sum(os.path.getsize(os.path.join(t, "base_psd", "S-layers", n))
                for n in os.listdir(os.path.join(t, "base_psd", "S-layers")))
    return {"png_bytes": sizes, "body": (bw, bh), "pins": len(doc["pins"])}


# -- setup helpers -------------------------------------------------------------------------------------
def base(fmt: str, scene="S"):
    """Copy the scene init made from char.FMT (pins and links auto) into out/."""
    def f(d):
        src = os.path.join(d, f"base_{fmt}")
        for n in os.listdir(src):
            dst = os.path.join(d, "out", n if n != "S.json" else scene + ".json")
            if os.path.isdir(os.path.join(src, n)):
                shutil.copytree(os.path.join(src, n), dst.replace("S-layers", scene + "-layers"), symlinks=True)
            else:
                shutil.copy(os.path.join(src, n), dst)
        if scene != "S":
            p = os.path.join(d, "out", scene + ".json")
            open(p, "w").write(open(p).read().replace('"S-layers/', f'"{scene}-layers/'))
    return f


def app_open(rel):
    """Open the art in the app's open path once (its scene ART.json made beside it)."""
    def f(d):
        subprocess.run([PY, "-c", APP.format(art=rel) + APP_END, d], check=True, capture_output=True, env=child_env(d))
    return f


def copy(src, dst):
    return lambda d: shutil.copy(os.path.join(d, src), os.path.join(d, dst))


def mkdir(rel):
    return lambda d: os.makedirs(os.path.join(d, rel), exist_ok=True)


def data(rel, make):
    """Write ``make()`` (bytes) or call ``make(path)`` to write the file at ``rel``."""
    def f(d):
        p = os.path.join(d, rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        out = make(p)
        if isinstance(out, bytes):
            open(p, "wb").write(out)
    return f


def tmpfs(rel, size="64k", ro=False, fill_up=True):
    """A tmpfs at ``rel`` (root only; unmounted after the case): full, or read-only."""
    from tests.cli.outputs_helpers import fill

    def f(d):
        where = os.path.join(d, rel)
        os.makedirs(where, exist_ok=True)
        if ro:
            subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size},ro", "tmpfs", where], check=True,
                           capture_output=True)
            return
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", where], check=True, capture_output=True)
        if fill_up:
            fill(where)
    return f


def fill_to(rel, size_bytes):
    """A tmpfs at ``rel`` with room for about ``size_bytes`` (the rest filled)."""
    def f(d):
        where = os.path.join(d, rel)
        os.makedirs(where, exist_ok=True)
        total = size_bytes + (1 << 20)
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={total}", "tmpfs", where], check=True, capture_output=True)
        with open(os.path.join(where, ".filler"), "wb") as fh:
            fh.write(b"\0" * (1 << 20))
    return f


# -- checks after a case -------------------------------------------------------------------------------
def scene_doc(d, rel):
    try:
        return json.load(open(os.path.join(d, rel)))
    except (OSError, ValueError):
        return None


def backup_kept(scene_rel):
    """--update that drops rig must keep the old scene: a new file with the old bytes."""
    def check(d, res, before, after):
        if res["rc"] != 0:
            return None
        old = before.get(scene_rel)
        new_files = [p for p, v in after.items() if p not in before and v == old]
        if not new_files:
            return f"--update replaced {scene_rel} and kept no copy of it"
    return check


def pins_kept(scene_rel, old_rel):
    """--update on renamed layers keeps every pin (layers mapped by content)."""
    def check(d, res, before, after):
        doc, old = scene_doc(d, scene_rel), scene_doc(d, old_rel)
        if res["rc"] == 0 and doc is not None and old is not None and len(doc.get("pins", [])) < len(old["pins"]):
            return f"--update on renamed layers kept {len(doc.get('pins', []))} of {len(old['pins'])} pins"
    return check


def html_no_comment_open(rel):
    def check(d, res, before, after):
        p = os.path.join(d, rel)
        if res["rc"] != 0 or not os.path.isfile(p):
            return None
        text = open(p, encoding="utf-8", errors="replace").read()
        low, pos = text.lower(), 0
        while (start := low.find("<script", pos)) >= 0:
            end = low.find("</script", start + 7)
            body = low[low.find(">", start) + 1:end if end >= 0 else len(low)]
            if "<!--" in body:
                return "a raw '<!--' inside the web player's <script> (the player does not start)"
            pos = end + 1 if end >= 0 else len(low)
    return check


def kind_respected(rel):
    """An existing folder at the output's name: exit 2, or a file written there."""
    def check(d, res, before, after):
        if res["rc"] == 0 and not os.path.isfile(os.path.join(d, rel)):
            return f"exit 0 but {rel} is not a file (the folder was filled with frames)"
    return check


def no_entity(scene_rel, word="EXPANDED"):
    def check(d, res, before, after):
        doc = scene_doc(d, scene_rel)
        if res["rc"] == 0 and doc is not None and word in json.dumps(doc):
            return "an XML entity was expanded into a layer name"
    return check


def render_ok(d: str, scene_rel: str, timeout: float) -> str | None:
    """`puppet render` of a scene the case wrote: None when it renders."""
    out = os.path.join(d, "check-render")
    os.makedirs(out, exist_ok=True)
    try:
        p = subprocess.run([PY, "-m", "puppet", "render", os.path.join(d, scene_rel), "-o", os.path.join(out, "x.png")],
                           capture_output=True, text=True, timeout=timeout, env=child_env(d), preexec_fn=_cap)
    except subprocess.TimeoutExpired:
        return f"render {scene_rel}: no answer in {timeout:.0f} s"
    if p.returncode != 0:
        return f"init exit 0 but render refuses {scene_rel}: {(p.stderr.strip().splitlines() or ['?'])[-1][:160]}"


# -- the cases ------------------------------------------------------------------------------------------
def init(art, scene="{d}/out/S.json", *flags):
    return ["init", art, "-o", scene, *flags]


OUT_S = ("out/S.json", "out/S-layers", "out/S-layers/*")
AUTO = ("--pins", "auto", "--links", "auto")


def section1() -> list[Case]:
    cases = []
    for fmt in FORMATS:
        art = f"{{d}}/in/char.{fmt}"
        cases += [
            Case(f"init {fmt}: S-layers a link to another folder", "1", init(art), outputs=("out/S.json",),
                 setup=[link("{d}/outside/dir", "out/S-layers")]),
            Case(f"init {fmt}: S-layers a dangling link outside", "1", init(art), outputs=("out/S.json",),
                 setup=[link("{d}/outside/new", "out/S-layers")]),
            # a named -o is written through (docs/cli.md); the layers go beside the link or its target
            Case(f"init {fmt}: -o a link to a file outside", "7", init(art), setup=[link("{d}/outside/precious.txt", "out/S.json")],
                 outputs=("outside/precious.txt", "outside/precious-layers", "outside/precious-layers/*") + OUT_S[1:],
                 renders=("out/S.json",)),
        ]
    sp = ["animate", "{d}/in/anim.json", "-o", "{d}/out/a.spine.json"]
    spj = ["animate", "{d}/in/anim.json", "-o", "{d}/out/a.json", "--format", "spine"]
    for what, argv, names in (("spine.json", sp, ("a.spine.atlas", "a.spine.png")),
                              ("json --format spine", spj, ("a.atlas", "a.png"))):
        outs = tuple("out/" + n for n in ("a.spine.json", "a.json") + names)
        for side in names:
            cases.append(Case(f"animate {what}: {side} a link to a file outside", "1", argv,
                              outputs=tuple(o for o in outs if not o.endswith(side)),
                              setup=[link("{d}/outside/precious.txt", f"out/{side}")]))
            cases.append(Case(f"animate {what}: {side} a dangling link outside", "1", argv,
                              outputs=tuple(o for o in outs if not o.endswith(side)),
                              setup=[link("{d}/outside/" + side, f"out/{side}")]))
        cases.append(Case(f"animate {what}: both side files links outside", "1", argv, outputs=outs[:2],
                          setup=[link("{d}/outside/precious.txt", f"out/{names[0]}"),
                                 link("{d}/outside/dir/body.png", f"out/{names[1]}")]))
    for ext in ("html", "glb", "spine.json"):
        cases.append(Case(f"animate .{ext}: -o a link outside (written through, as named)", "held",
                          ["animate", "{d}/in/anim.json", "-o", f"{{d}}/out/a.{ext}"],
                          outputs=("outside/precious.txt", "outside/precious.spine.*", "out/a.spine.*"),
                          setup=[link("{d}/outside/precious.txt", f"out/a.{ext}")]))
    return cases


def section2() -> list[Case]:
    cases = []
    user_png = lambda p=None: artfiles.png_bytes(solid(7, 7, (1, 2, 3, 255)))  # noqa: E731
    for fmt in FORMATS:
        art = f"{{d}}/in/char.{fmt}"
        cases += [
            Case(f"init {fmt}: the user's own S-layers/body.png", "2", init(art), outputs=OUT_S,
                 protect=("out/S-layers/body.png",), setup=[data("out/S-layers/body.png", user_png)], renders=("out/S.json",)),
            Case(f"init {fmt}: the user's own S-layers/body.png, --force", "2", init(art, "{d}/out/S.json", "--force"),
                 outputs=OUT_S, setup=[data("out/S-layers/body.png", user_png)], renders=("out/S.json",), expect_ok=True),
            Case(f"init {fmt}: a user's notes in S-layers/", "2", init(art), outputs=OUT_S,
                 protect=("out/S-layers/notes.txt",), setup=[write("out/S-layers/notes.txt", "mine")], renders=("out/S.json",)),
            Case(f"init {fmt}: S-layers/head.png a link to a file outside", "2", init(art), outputs=OUT_S,
                 protect=("out/S-layers/head.png",),
                 setup=[mkdir("out/S-layers"), link("{d}/outside/precious.txt", "out/S-layers/head.png")]),
            Case(f"init {fmt}: S-layers/head.png a link to the user's file beside", "2", init(art), outputs=OUT_S,
                 protect=("out/S-layers/head.png", "out/mine.png"),
                 setup=[data("out/mine.png", user_png), mkdir("out/S-layers"), link("../mine.png", "out/S-layers/head.png")]),
        ]
    for fmt in ("psd", "ora", "kra"):
        cases.append(Case(f"init {fmt} --update: the art gains a layer named as the scene's stiffness image", "2",
                          init(f"{{d}}/in/plus.{fmt}", "{d}/out/S.json", "--update"), outputs=OUT_S + ("out/S.json*",),
                          protect=("out/S-layers/stiff.png",), setup=[base("stiff")], renders=("out/S.json",)))
    cases.append(Case("init psd --update: S-layers/head.png made a link by the user", "2",
                      init("{d}/in/recolour.psd", "{d}/out/S.json", "--update"), outputs=OUT_S + ("out/S.json*",),
                      protect=("out/S-layers/head.png", "out/mine.png"),
                      setup=[base("psd"), lambda d: os.rename(os.path.join(d, "out/S-layers/head.png"),
                                                              os.path.join(d, "out/mine.png")),
                             link("../mine.png", "out/S-layers/head.png")], renders=("out/S.json",)))
    cases.append(Case("init psd over a scene of the same name not made from art", "2",
                      init("{d}/in/char.psd"), outputs=OUT_S, protect=("out/S-layers/bar.png",),
                      setup=[data("out/S-layers/bar.png", user_png)], renders=("out/S.json",)))
    return cases


def section3(facts) -> list[Case]:
    cases = []
    for fmt in FORMATS:
        upd = lambda art: init(art, "{d}/out/S.json", "--update")  # noqa: E731
        cases += [
            Case(f"init {fmt} --update: layer and group renamed in the art", "3", upd(f"{{d}}/in/renamed.{fmt}"),
                 outputs=OUT_S + ("out/S.json*", "out/S*.json"), setup=[base(fmt)], renders=("out/S.json",),
                 checks=[backup_kept("out/S.json"), pins_kept("out/S.json", f"base_{fmt}/S.json")]),
            Case(f"init {fmt} --update: unrelated art", "3", upd(f"{{d}}/in/other.{fmt}"),
                 outputs=OUT_S + ("out/S.json*", "out/S*.json"), setup=[base(fmt)], renders=("out/S.json",),
                 checks=[backup_kept("out/S.json")]),
            Case(f"init {fmt} --update: recoloured art (held)", "held", upd(f"{{d}}/in/recolour.{fmt}"),
                 outputs=OUT_S + ("out/S.json*", "out/S*.json"), setup=[base(fmt)], renders=("out/S.json",), expect_ok=True),
            Case(f"init {fmt} --update --pins auto --links auto: the same art (held)", "held",
                 upd(f"{{d}}/in/char.{fmt}") + list(AUTO),
                 outputs=OUT_S + ("out/S.json*", "out/S*.json"), setup=[base(fmt)], renders=("out/S.json",), expect_ok=True),
        ]
    cases.append(Case("app open: ART.json beside renamed art (an update)", "3",
                      script=APP.format(art="out/char.psd"),
                      setup=[copy("in/char.psd", "out/char.psd"), app_open("out/char.psd"), copy("out/char.json", "char-before.json"),
                             copy("in/renamed.psd", "out/char.psd")],
                      outputs=("out/char.json*", "out/char-layers", "out/char-layers/*", "out/char*.json"),
                      checks=[backup_kept("out/char.json"), pins_kept("out/char.json", "char-before.json")],
                      renders=("out/char.json",)))
    return cases


def section4(facts) -> list[Case]:
    cases = []
    room = facts["png_bytes"]
    for fmt in ("psd", "ora", "kra"):
        for k, extra in enumerate((-8192, 0, 2048, 4096, 8192, 16384, 32768)):
            cases.append(Case(f"init {fmt}: a disk that fills at {room + extra} bytes ({k})", "4",
                              init(f"{{d}}/in/char.{fmt}", "{d}/out/full/S.json", *AUTO),
                              setup=[fill_to("out/full", max(room + extra, 4096))],
                              outputs=("out/full/S.json", "out/full/S-layers", "out/full/S-layers/*"),
                              renders=("out/full/S.json",)))
        cases.append(Case(f"init {fmt}: a full disk", "4", init(f"{{d}}/in/char.{fmt}", "{d}/out/full/S.json"),
                          setup=[tmpfs("out/full")]))
        cases.append(Case(f"init {fmt}: a read-only folder", "4", init(f"{{d}}/in/char.{fmt}", "{d}/out/ro/S.json"),
                          setup=[tmpfs("out/ro", ro=True)]))
    for ext in ("html", "glb", "spine.json", "gif"):
        cases.append(Case(f"animate .{ext} into a full disk", "4", ["animate", "{d}/in/anim.json", "-o", f"{{d}}/out/full/a.{ext}"],
                          setup=[tmpfs("out/full")]))
    for what in ("truncated PSD", "every layer hidden (ORA)", "an ORA with an entity", "not a zip (KRA)"):
        if what.startswith("truncated"):
            setup, art = [lambda d: open(os.path.join(d, "out/bad.psd"), "wb").write(
                open(os.path.join(d, "in/char.psd"), "rb").read()[:5000])], "out/bad.psd"
        elif what.startswith("every"):
            setup, art = [data("out/bad.ora", lambda p: ora_doc(p, ora_layer("a", visibility="hidden"),
                                                               {"data/a.png": artfiles.png_bytes(solid(5, 5))}))], "out/bad.ora"
        elif "entity" in what:
            setup, art = [data("out/bad.ora", lambda p: ora_doc(
                p, '<?xml version="1.0"?><!DOCTYPE i [<!ENTITY e "x">]><image w="9" h="9"><stack>'
                   + ora_layer("&e;") + "</stack></image>", {"data/a.png": artfiles.png_bytes(solid(5, 5))},
                head=False))], "out/bad.ora"
        else:
            setup, art = [write("out/bad.kra", b"PK\x03\x04 not really")], "out/bad.kra"
        cases.append(Case(f"app open: {what} (refused)", "4", script=APP.format(art=art), setup=setup))
    for fmt in ("ora", "kra"):
        cases.append(Case(f"app open: a {fmt} in a read-only folder", "4", script=APP.format(art=f"out/ro/char.{fmt}"),
                          setup=[mkdir("out/ro"), copy(f"in/char.{fmt}", f"out/ro/char.{fmt}"),
                                 lambda d: subprocess.run(["mount", "--bind", "-o", "ro", os.path.join(d, "out/ro"),
                                                           os.path.join(d, "out/ro")], check=True, capture_output=True)]))
    for fmt in ("psd", "ora", "kra"):  # the import succeeds, the scene it wrote is then refused by the load
        cases.append(Case(f"app open: a {fmt} of 1x1 and 1x40 px layers only (imported, then refused)", "4",
                          script=APP.format(art=f"out/tiny.{fmt}"), setup=[data(f"out/tiny.{fmt}", lambda p: write_art(
                              p, [("tiny", None, solid(1, 1), (60, 60)), ("thin", None, solid(1, 40), (10, 10))], (100, 100)))],
                          outputs=("out/tiny.json", "out/tiny-layers", "out/tiny-layers/*"), renders=("out/tiny.json",)))
    cases.append(Case("app open: a psd whose ART-layers/ is a file", "4", script=APP.format(art="out/char.psd"),
                      setup=[copy("in/char.psd", "out/char.psd"), write("out/char-layers", "x")]))
    return cases


def kra_bomb(path, layers, side, *, same_member=True):
    """``layers`` paint layers of side x side pixels whose tiles are one constant LZF tile."""
    tile = b"\x01" + lzf_compress(bytes([90]) * (64 * 64 * 4))
    n = side // 64
    body = b"".join(f"{x * 64},{y * 64},LZF,{len(tile)}\n".encode() + tile for y in range(n) for x in range(n))
    tf = f"VERSION 2\nTILEWIDTH 64\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA {n * n}\n".encode() + body
    xml = "".join(f'<layer name="l{k}" filename="{"t" if same_member else f"t{k}"}" nodetype="paintlayer" visible="1" '
                  f'opacity="255" x="0" y="0" colorspacename="RGBA"/>' for k in range(layers))
    members = {"d/layers/t": tf} if same_member else {f"d/layers/t{k}": tf for k in range(layers)}
    kra_doc(path, xml, members, w=side, h=side)


def kra_cpu(path, copies):
    """One layer whose tile list repeats the same LZF tile ``copies`` times (each decoded in Python)."""
    tile = b"\x01" + bytes([0]) + b"z" + bytes([1 << 5, 0]) * 5461  # 5461 back-references of 3 bytes
    tf = (f"VERSION 2\nTILEWIDTH 64\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA {copies}\n".encode()
          + (f"0,0,LZF,{len(tile)}\n".encode() + tile) * copies)
    kra_doc(path, '<layer name="l" filename="t" nodetype="paintlayer" visible="1" opacity="255" x="0" y="0" '
            'colorspacename="RGBA"/>', {"d/layers/t": tf}, w=64, h=64)


def ora_bomb(path, layers, side):
    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGBA", (side, side), (10, 200, 30, 255)).save(buf, format="PNG", optimize=False)
    ora_doc(path, "".join(ora_layer(f"l{k}", "data/big.png") for k in range(layers)), {"data/big.png": buf.getvalue()},
            w=side, h=side)


def many_layers(path, n):
    rng = random.Random(3)
    items = []
    for k in range(n):
        a = solid(12, 12, (rng.randrange(256), 90, 90, 255))
        a[:3, :3, 3] = 0
        items.append((f"p{k}", None, a, (rng.randrange(0, 1980), rng.randrange(0, 1980))))
    write_art(path, items, (2000, 2000))


def section5() -> list[Case]:
    cases = [
        Case("init kra: 60 layers of 8192² sharing one tile member", "5", init("{d}/in/bomb.kra"),
             setup=[data("in/bomb.kra", lambda p: kra_bomb(p, 60, 8192))], outputs=OUT_S),
        Case("init kra: 8 layers of 8192² sharing one tile member", "5", init("{d}/in/bomb.kra"),
             setup=[data("in/bomb.kra", lambda p: kra_bomb(p, 8, 8192))], outputs=OUT_S),
        Case("init ora: 100 layers of 32 MP, one PNG", "5", init("{d}/in/bomb.ora"),
             setup=[data("in/bomb.ora", lambda p: ora_bomb(p, 100, 5700))], outputs=OUT_S),
        Case("init ora: 12 layers of 32 MP, one PNG", "5", init("{d}/in/bomb.ora"),
             setup=[data("in/bomb.ora", lambda p: ora_bomb(p, 12, 5700))], outputs=OUT_S),
        Case("init kra: one LZF tile repeated 12000 times", "5", init("{d}/in/cpu.kra"),
             setup=[data("in/cpu.kra", lambda p: kra_cpu(p, 12000))], outputs=OUT_S),
        Case("init ora: 2000 small layers --pins auto --links auto", "5", init("{d}/in/many.ora", "{d}/out/S.json", *AUTO),
             setup=[data("in/many.ora", lambda p: many_layers(p, 2000))], outputs=OUT_S, renders=("out/S.json",)),
        Case("init ora: 2000 small layers, plain (held)", "held", init("{d}/in/many.ora"),
             setup=[data("in/many.ora", lambda p: many_layers(p, 2000))], outputs=OUT_S),
        # 80001 frames held in memory: under a 1.5 GB cap the blow-up comes within the timeout
        Case("animate spine.json: 4000 s", "5", ["animate", "{d}/in/long.json", "-o", "{d}/out/a.spine.json"],
             outputs=("out/a.spine.*",), memory_cap=3 << 29),
        Case("animate glb: 4000 s", "5", ["animate", "{d}/in/long.json", "-o", "{d}/out/a.glb"], outputs=("out/a.glb",)),
        Case("animate html: 4000 s at 0.1 fps, under a 1.5 GB cap (held)", "held",
             ["animate", "{d}/in/long.json", "-o", "{d}/out/a.html", "--fps", "0.1"], outputs=("out/a.html",),
             memory_cap=3 << 29, expect_ok=True),
    ]
    return cases


def section6() -> list[Case]:
    cases = []
    png = artfiles.png_bytes(solid(20, 20))
    a_png = {"data/a.png": png}
    # encrypted members
    for what, maker, member_name in (
            ("ora stack.xml", lambda p: ora_doc(p, ora_layer("a"), a_png), "stack.xml"),
            ("ora layer PNG", lambda p: ora_doc(p, ora_layer("a"), a_png), "data/a.png"),
            ("kra maindoc.xml", lambda p: kra_layers(p, [("a", None, solid(20, 20), (0, 0))]), "maindoc.xml"),
            ("kra tile member", lambda p: kra_layers(p, [("a", None, solid(20, 20), (0, 0))]), "d/layers/l0")):
        ext = what.split()[0]

        def make(p, maker=maker, member_name=member_name):
            maker(p)
            encrypt_member(p, member_name)
        cases.append(Case(f"init {what} encrypted", "6", init(f"{{d}}/in/enc.{ext}"), setup=[data(f"in/enc.{ext}", make)],
                          outputs=OUT_S))
        cases.append(Case(f"app open: {what} encrypted", "6", script=APP.format(art=f"out/enc.{ext}"),
                          setup=[data(f"out/enc.{ext}", make)]))
    for v in ("1e400", "-inf", "1e300", "nan", "inf", "-1e300", "99999999999999999999", "0x10", ""):
        for axis in ("x", "y"):
            attrs = {axis: v}
            cases.append(Case(f"init ora: {axis}={v!r}", "6", init("{d}/in/c.ora"), outputs=OUT_S,
                              setup=[data("in/c.ora", lambda p, a=attrs: ora_doc(p, ora_layer("a", **dict({"x": 0, "y": 0}, **a)),
                                                                                 a_png))]))
        cases.append(Case(f"init kra: x={v!r}", "6", init("{d}/in/c.kra"), outputs=OUT_S,
                          setup=[data("in/c.kra", lambda p, v=v: kra_layers(p, [("a", None, solid(20, 20), (0, 0))],
                                                                            attrs={"x": v}))]))
    for v in ("1e400", "nan", "-inf"):
        for key in ("w", "h"):
            cases.append(Case(f"init ora: document {key}={v}", "6", init("{d}/in/c.ora"), outputs=OUT_S,
                              setup=[data("in/c.ora", lambda p, k=key, v=v: ora_doc(
                                  p, f'<image {k}="{v}" {"h" if k == "w" else "w"}="50"><stack>{ora_layer("a")}</stack></image>',
                                  a_png, head=False))]))
    for v in ("abc", "0.5", "-5", "1e400", "", "300", "nan"):
        cases.append(Case(f"init kra: opacity {v!r}", "6", init("{d}/in/c.kra"), outputs=OUT_S,
                          setup=[data("in/c.kra", lambda p, v=v: kra_layers(p, [("a", None, solid(20, 20), (0, 0))],
                                                                            attrs={"opacity": v}))]))
    for v in ("abc", "1e400", "nan", "-1"):
        cases.append(Case(f"init ora: opacity {v!r}", "6", init("{d}/in/c.ora"), outputs=OUT_S,
                          setup=[data("in/c.ora", lambda p, v=v: ora_doc(p, ora_layer("a", opacity=v), a_png))]))
    for depth in (1000, 5000):
        cases.append(Case(f"init ora: groups nested {depth} deep", "6", init("{d}/in/deep.ora"), outputs=OUT_S,
                          setup=[data("in/deep.ora", lambda p, n=depth: ora_doc(
                              p, '<stack name="g">' * n + ora_layer("a") + "</stack>" * n, a_png))]))
        cases.append(Case(f"init kra: groups nested {depth} deep", "6", init("{d}/in/deep.kra"), outputs=OUT_S,
                          setup=[data("in/deep.kra", lambda p, n=depth: kra_doc(
                              p, '<layer name="g" nodetype="grouplayer" visible="1"><layers>' * n
                              + '<layer name="a" filename="a" nodetype="paintlayer" visible="1" x="0" y="0"/>'
                              + "</layers></layer>" * n, {"d/layers/a": tile_file(solid(20, 20))}))]))
        cases.append(Case(f"app open: ora groups nested {depth} deep", "6", script=APP.format(art="out/deep.ora"),
                          setup=[data("out/deep.ora", lambda p, n=depth: ora_doc(
                              p, '<stack name="g">' * n + ora_layer("a") + "</stack>" * n, a_png))]))
    cases.append(Case("app open: kra opacity 'abc'", "6", script=APP.format(art="out/c.kra"),
                      setup=[data("out/c.kra", lambda p: kra_layers(p, [("a", None, solid(20, 20), (0, 0))],
                                                                      attrs={"opacity": "abc"}))]))
    cases.append(Case("app open: ora x=1e400", "6", script=APP.format(art="out/c.ora"),
                      setup=[data("out/c.ora", lambda p: ora_doc(p, ora_layer("a", x="1e400"), a_png))]))
    # the editing API
    api = {
        "drag(size=(0, 0))": "s.drag(PIN, size=(0, 0)).move((200, 300))",
        "drag(size=(100000, 100000)) and release": "d = s.drag(PIN, size=(100000, 100000)); d.move((200, 300)); d.release()",
        "drag(size=(-5, 10))": "s.drag(PIN, size=(-5, 10)).move((200, 300))",
        "drag(size='big')": "s.drag(PIN, size='big').move((200, 300))",
        "drag move to a string": "s.drag(PIN).move('left')",
        "drag move to ('a', 'b')": "s.drag(PIN).move(('a', 'b'))",
        "drag move {pin: 'x'}": "s.drag(PIN).move({PIN: 'x'})",
        "drag move to (nan, nan)": "d = s.drag(PIN); d.move((float('nan'), float('nan'))); d.release()",
        "drag move to (1e300, 0)": "d = s.drag(PIN); d.move((1e300, 0)); d.release()",
        "drag an unknown pin": "s.drag('nope')",
        "drag pin 5": "s.drag(5)",
        "drag time='x'": "s.drag(PIN, time='x')",
        "set_stiffness_pixels a string": "s.set_stiffness_pixels('body', 'grey')",
        "set_stiffness_pixels unknown layer": "s.set_stiffness_pixels('nope', np.zeros((BH, BW), np.uint8))",
        "save(5)": "s.save(5)",
        "save(None)": "s.save(None)",
        "save(b'x.json')": "s.save(D.encode() + b'/out/x.json')",
        "save to a folder": "s.save(D + '/out')",
        "save over the art": "s.save(D + '/in/char.psd')",
        "split_layer an unknown layer": "s.split_layer('nope', [[0, 0], [10, 0], [10, 10]], 'n')",
        "split_layer region a string": "s.split_layer('body', 'all', 'n')",
        "split_layer region 2 points": "s.split_layer('body', [[150, 250], [160, 260]], 'n')",
        "split_layer region outside": "s.split_layer('body', [[-900, -900], [-800, -900], [-800, -800]], 'n')",
        "split_layer region nan": "s.split_layer('body', [[float('nan'), 0], [10, 0], [10, 10]], 'n')",
        "split_layer name taken": "s.split_layer('body', [[140, 230], [200, 230], [200, 300]], 'head')",
        "split_layer name ''": "s.split_layer('body', [[140, 230], [200, 230], [200, 300]], '')",
        "split_layer name 5": "s.split_layer('body', [[140, 230], [200, 230], [200, 300]], 5)",
        "split_layer mask of the wrong shape": "s.split_layer('body', np.ones((3, 3), bool), 'n')",
        "add_link_point nan": "s.add_link_point('body', 'head', (float('nan'), 0))",
        "add_link_point far outside": "s.add_link_point('body', 'head', (1e9, 1e9))",
        "add_link_polygon 2 points": "s.add_link_polygon('body', 'neck', [[150, 230], [160, 230]])",
        "add_link_polygon 2000 points": "s.add_link_polygon('body', 'neck', [[150 + k % 7, 230 + k % 5] for k in range(2000)])",
        "add_link_polygon nan": "s.add_link_polygon('body', 'neck', [[float('nan'), 0], [1, 0], [1, 1]])",
        "set_link_strength -1": "s.set_link_strength(*LINK, -1)",
        "set_link_strength 2": "s.set_link_strength(*LINK, 2)",
        "set_link_strength nan": "s.set_link_strength(*LINK, float('nan'))",
        "set_link_strength 'x'": "s.set_link_strength(*LINK, 'x')",
        "set_pin_radius -1": "s.set_pin(SPIN, kind='starch'); s.set_pin_radius(SPIN, -1)",
        "set_pin_radius nan": "s.set_pin(SPIN, kind='starch'); s.set_pin_radius(SPIN, float('nan'))",
    }
    for name, call in api.items():
        cases.append(Case(f"api {name}", "6" if "drag" in name or "stiffness" in name or "save" in name else "held",
                          script=API.format(body=call), outputs=("out/x.json",)))
    refuse = {
        "set_stiffness_pixels of the wrong shape": "s.set_stiffness_pixels('body', np.full((3, 3), 99, np.uint8))",
        "set_stiffness_pixels 3-d": "s.set_stiffness_pixels('body', np.full((BH, BW, 3), 99, np.uint8))",
        "set_stiffness_pixels NaN": "s.set_stiffness_pixels('body', np.full((BH, BW), np.nan))",
        "set_stiffness_pixels negative": "s.set_stiffness_pixels('body', np.full((BH, BW), -50.0))",
        "set_stiffness_pixels 1e9": "s.set_stiffness_pixels('body', np.full((BH, BW), 1e9))",
        "drag(iterations=-5)": "d = s.drag(PIN, iterations=-5); d.move((200, 300)); d.release()",
        "drag(iterations=0)": "d = s.drag(PIN, iterations=0); d.move((200, 300)); d.release()",
    }
    for name, call in refuse.items():
        cases.append(Case(f"api {name} (must be refused)", "6", outputs=("out/x.json", "out/x.files", "out/x.files/*"),
                          script=API.format(body=call + "\n    s.save(D + '/out/x.json'); s.render()\n    sys.exit(5)")))
    return cases


def section7() -> list[Case]:
    cases = [
        Case("animate html: layers named '<!--<script>' and '</script>'", "7",
             ["animate", "{d}/in/evil.json", "-o", "{d}/out/a.html"], outputs=("out/a.html",),
             checks=[html_no_comment_open("out/a.html")]),
    ]
    for ext in ("html", "glb", "spine.json", "gltf", "gif", "mp4"):
        cases.append(Case(f"animate: an empty folder at out/a.{ext}", "7", ["animate", "{d}/in/anim.json", "-o", f"{{d}}/out/a.{ext}"],
                          setup=[mkdir(f"out/a.{ext}")], outputs=(f"out/a.{ext}", f"out/a.{ext}/*", "out/a.spine.*"),
                          checks=[kind_respected(f"out/a.{ext}")]))
    tiny = {"1x1": solid(1, 1), "2x2": solid(2, 2), "1x40": solid(1, 40), "2x60": solid(60, 2)}
    for fmt in ("psd", "ora", "kra"):
        for what, a in tiny.items():
            cases.append(Case(f"init {fmt}: a {what} px layer beside a normal one", "7", init(f"{{d}}/in/tiny.{fmt}"),
                              outputs=OUT_S, renders=("out/S.json",),
                              setup=[data(f"in/tiny.{fmt}", lambda p, a=a: write_art(
                                  p, [("big", None, solid(40, 40), (5, 5)), ("tiny", None, a, (60, 60))], (100, 100)))]))
        cases.append(Case(f"init {fmt} -o through a folder link", "7", init(f"{{d}}/in/char.{fmt}", "{d}/out/link/S.json"),
                          setup=[mkdir("out/real"), link("{d}/out/real", "out/link")],
                          outputs=("out/real/S.json", "out/real/S-layers", "out/real/S-layers/*"),
                          renders=("out/link/S.json", "out/real/S.json")))
        cases.append(Case(f"init {fmt} -o LINK.json, a link into another folder", "7",
                          init(f"{{d}}/in/char.{fmt}", "{d}/out/LINK.json"),
                          setup=[mkdir("out/real"), link("real/S.json", "out/LINK.json")],
                          outputs=("out/real/S.json", "out/real/S-layers", "out/real/S-layers/*", "out/LINK-layers",
                                   "out/LINK-layers/*", "out/LINK.json"),
                          renders=("out/LINK.json", "out/real/S.json")))
    png = artfiles.png_bytes(solid(20, 20))
    for enc in ("utf-16", "utf-16-le", "utf-16-be", "utf-8-sig", "utf-32"):
        def make(p, enc=enc):
            text = (f'<?xml version="1.0" encoding="{enc.replace("-sig", "")}"?><!DOCTYPE image [<!ENTITY e "EXPANDED">]>'
                    f'<image w="50" h="50"><stack>{ora_layer("&e;")}</stack></image>').replace('"&amp;e;"', '"&e;"')
            body = text.encode(enc)
            if enc in ("utf-16-le", "utf-16-be"):
                body = ("\ufeff" + text).encode(enc)
            ora_doc(p, body, {"data/a.png": png}, head=False)
        cases.append(Case(f"init ora: stack.xml in {enc} with an entity", "7", init("{d}/in/x.ora"), outputs=OUT_S,
                          setup=[data("in/x.ora", make)], checks=[no_entity("out/S.json")]))
    return cases


def section8() -> list[Case]:
    cases = []
    a = solid(20, 20)
    for fmt in ("psd", "ora", "kra"):
        for what, items in (("a 255-character layer name", [("n" * 255, None, a, (0, 0))]),
                            ("a 255-character unicode name", [("é" * 255, None, a, (0, 0))]),
                            ("layers 'Head' and 'head'", [("Head", None, a, (0, 0)), ("head", None, a, (30, 30))]),
                            ("layers '..', '.', 'CON' and 'a/b'", [("..", None, a, (0, 0)), (".", None, a, (25, 0)),
                                                                  ("CON", None, a, (50, 0)), ("a/b", None, a, (0, 40))])):
            cases.append(Case(f"init {fmt}: {what}", "8" if "255" in what else "held", init(f"{{d}}/in/n.{fmt}"),
                              outputs=OUT_S, expect_ok=True, renders=("out/S.json",),
                              setup=[data(f"in/n.{fmt}", lambda p, items=items: write_art(p, items, (100, 100)))]))
    png = artfiles.png_bytes(a)
    cases.append(Case("init ora: a 5000-character name", "8", init("{d}/in/n.ora"), outputs=OUT_S, expect_ok=True,
                      renders=("out/S.json",), setup=[data("in/n.ora", lambda p: ora_doc(p, ora_layer("x" * 5000), {"data/a.png": png}))]))
    cases.append(Case("init ora: a 200-deep group path", "8", init("{d}/in/n.ora"), outputs=OUT_S, expect_ok=True,
                      renders=("out/S.json",), setup=[data("in/n.ora", lambda p: ora_doc(
                          p, '<stack name="group">' * 200 + ora_layer("a") + "</stack>" * 200, {"data/a.png": png}))]))
    cases.append(Case("init kra: a 200-deep group path", "8", init("{d}/in/n.kra"), outputs=OUT_S, expect_ok=True,
                      renders=("out/S.json",), setup=[data("in/n.kra", lambda p: kra_doc(
                          p, '<layer name="group" nodetype="grouplayer" visible="1"><layers>' * 200
                          + '<layer name="a" filename="a" nodetype="paintlayer" visible="1" x="0" y="0"/>'
                          + "</layers></layer>" * 200, {"d/layers/a": tile_file(a)}))]))
    cases.append(Case("init ora: two 300-character names alike to the last character", "8", init("{d}/in/n.ora"),
                      outputs=OUT_S, expect_ok=True, renders=("out/S.json",),
                      setup=[data("in/n.ora", lambda p: ora_doc(p, ora_layer("x" * 299 + "1") + ora_layer("x" * 299 + "2", x=30),
                                                                {"data/a.png": png}))]))
    return cases


def section9() -> list[Case]:
    return [
        Case("render: a starch radius of 1e-300", "9", ["render", "{d}/in/starch.json", "-o", "{d}/out/r.png"],
             outputs=("out/r.png",)),
        Case("api set_pin_radius 1e-300", "9", script=API.format(
            body="s.set_pin(SPIN, kind='starch'); s.set_pin_radius(SPIN, 1e-300); s.render()")),
        Case("api set_pin_radius 1e-12", "9", script=API.format(
            body="s.set_pin(SPIN, kind='starch'); s.set_pin_radius(SPIN, 1e-12); s.render()")),
        Case("animate gif: a starch radius of 1e-300", "9", ["animate", "{d}/in/starch.json", "-o", "{d}/out/a.gif"],
             outputs=("out/a.gif",)),
    ]


# -- what the issue says held -------------------------------------------------------------------------
def psd_header(src, **fields):
    """The PSD at ``src`` with header fields replaced (version, channels, height, width, depth, mode)."""
    def make(p):
        b = bytearray(open(src.format(d=os.path.dirname(os.path.dirname(p))), "rb").read())
        at = {"version": (4, ">H"), "channels": (12, ">H"), "height": (14, ">I"), "width": (18, ">I"),
              "depth": (22, ">H"), "mode": (24, ">H")}
        for k, v in fields.items():
            struct.pack_into(at[k][1], b, at[k][0], v)
        return bytes(b)
    return make


def held() -> list[Case]:
    cases = []
    for fmt in FORMATS:
        for k in range(30):
            frac = (k + 0.5) / 30

            def cut(p, fmt=fmt, frac=frac):
                src = open(os.path.join(os.path.dirname(os.path.dirname(p)), "in", f"char.{fmt}"), "rb").read()
                open(p, "wb").write(src[:max(1, int(len(src) * frac ** 2))])  # denser near the start (headers)
            cases.append(Case(f"init {fmt}: truncated at {frac ** 2:.4f}", "held", init(f"{{d}}/in/t.{fmt}"),
                              setup=[data(f"in/t.{fmt}", cut)], outputs=OUT_S, renders=("out/S.json",)))
        for k in range(10):
            def flip(p, fmt=fmt, k=k):
                src = bytearray(open(os.path.join(os.path.dirname(os.path.dirname(p)), "in", f"char.{fmt}"), "rb").read())
                rng = random.Random(k)
                for _ in range(8):
                    at = rng.randrange(min(len(src), 4096) if k < 5 else len(src))
                    src[at] ^= 1 << rng.randrange(8)
                open(p, "wb").write(bytes(src))
            cases.append(Case(f"init {fmt}: 8 bits flipped (seed {k})", "held", init(f"{{d}}/in/t.{fmt}"),
                              setup=[data(f"in/t.{fmt}", flip)], outputs=OUT_S, renders=("out/S.json",)))
        cases += [
            Case(f"init {fmt}: a FIFO", "held", init(f"{{d}}/in/f.{fmt}"), setup=[fifo(f"in/f.{fmt}")]),
            Case(f"init {fmt}: /dev/zero", "held", init(f"{{d}}/in/z.{fmt}"), setup=[link("/dev/zero", f"in/z.{fmt}")]),
            Case(f"init {fmt}: /dev/urandom", "held", init(f"{{d}}/in/z.{fmt}"), setup=[link("/dev/urandom", f"in/z.{fmt}")]),
            Case(f"init {fmt}: an empty file", "held", init(f"{{d}}/in/e.{fmt}"), setup=[write(f"in/e.{fmt}", b"")]),
            Case(f"init {fmt}: a folder", "held", init(f"{{d}}/in/f.{fmt}"), setup=[mkdir(f"in/f.{fmt}")]),
            Case(f"init {fmt}: missing", "held", init(f"{{d}}/in/none.{fmt}")),
            Case(f"init {fmt}: -o the art itself", "held", init(f"{{d}}/in/char.{fmt}", f"{{d}}/in/char.{fmt}")),
            Case(f"init {fmt}: -o a FIFO", "held", init(f"{{d}}/in/char.{fmt}"), setup=[fifo("out/S.json")]),
            Case(f"init {fmt}: S-layers is a file", "held", init(f"{{d}}/in/char.{fmt}"), setup=[write("out/S-layers", "x")]),
            Case(f"init {fmt} --update without a scene", "held", init(f"{{d}}/in/char.{fmt}", "{d}/out/S.json", "--update")),
            Case(f"init {fmt}: SIGINT at 0.8 s", "held", init(f"{{d}}/in/char.{fmt}", "{d}/out/S.json", *AUTO),
                 outputs=OUT_S, signal_after=(signal.SIGINT, 0.8), renders=("out/S.json",)),
            Case(f"init {fmt}: SIGTERM at 0.8 s", "held", init(f"{{d}}/in/char.{fmt}", "{d}/out/S.json", *AUTO),
                 outputs=OUT_S, signal_after=(signal.SIGTERM, 0.8), renders=("out/S.json",)),
            Case(f"init {fmt}: SIGTERM at 1.6 s", "held", init(f"{{d}}/in/char.{fmt}", "{d}/out/S.json", *AUTO),
                 outputs=OUT_S, signal_after=(signal.SIGTERM, 1.6), renders=("out/S.json",)),
            Case(f"init {fmt} --update: SIGINT at 1.2 s", "held", init(f"{{d}}/in/recolour.{fmt}", "{d}/out/S.json", "--update"),
                 setup=[base(fmt)], outputs=OUT_S + ("out/S.json*",), signal_after=(signal.SIGINT, 1.2), renders=("out/S.json",)),
        ]
    for fmt, ver in (("psd", 1), ("psb", 2)):
        src = "{d}/in/char." + fmt
        for what, fields in (("300000² document", dict(width=300000, height=300000)),
                             ("width 0", dict(width=0)), ("height 2^32-1", dict(height=2 ** 32 - 1)),
                             ("0 channels", dict(channels=0)), ("57 channels", dict(channels=57)),
                             ("depth 3", dict(depth=3)), ("depth 32", dict(depth=32)), ("mode 99", dict(mode=99)),
                             ("version 7", dict(version=7)), ("version of the other kind", dict(version=3 - ver))):
            cases.append(Case(f"init {fmt}: header says {what}", "held", init(f"{{d}}/in/h.{fmt}"), outputs=OUT_S,
                              setup=[data(f"in/h.{fmt}", psd_header(src, **fields))], renders=("out/S.json",)))
    png = artfiles.png_bytes(solid(20, 20))
    big_png_header = bytearray(artfiles.png_bytes(solid(1, 1)))
    struct.pack_into(">II", big_png_header, 16, 100000, 100000)
    zips = {
        "ora layer src '../../outside/precious.txt'": ("ora", lambda p: ora_doc(p, ora_layer("a", "../../outside/precious.txt"), {})),
        "ora layer src '/etc/passwd'": ("ora", lambda p: ora_doc(p, ora_layer("a", "/etc/passwd"), {})),
        "ora member named '../../outside/x.png'": ("ora", lambda p: ora_doc(p, ora_layer("a", "../../outside/x.png"),
                                                                           {"../../outside/x.png": png})),
        "ora member a symlink": ("ora", lambda p: symlink_member(p)),
        "kra filename '../../../outside/precious.txt'": ("kra", lambda p: kra_doc(
            p, '<layer name="a" filename="../../../outside/precious.txt" nodetype="paintlayer" visible="1"/>', {})),
        "ora XXE SYSTEM file": ("ora", lambda p: ora_doc(
            p, '<?xml version="1.0"?><!DOCTYPE i [<!ENTITY e SYSTEM "file:///etc/passwd">]><image w="9" h="9"><stack>'
               '<layer name="&e;" src="data/a.png"/></stack></image>', {"data/a.png": png}, head=False)),
        "ora billion laughs": ("ora", lambda p: ora_doc(
            p, '<?xml version="1.0"?><!DOCTYPE i [<!ENTITY a "aaaaaaaaaa">' + "".join(
                f'<!ENTITY {chr(98 + k)} "' + f"&{chr(97 + k)};" * 10 + '">' for k in range(9))
            + ']><image w="9" h="9"><stack><layer name="&j;" src="data/a.png"/></stack></image>', {"data/a.png": png}, head=False)),
        "kra XXE in maindoc.xml": ("kra", lambda p: zip_members(p, {"maindoc.xml": '<?xml version="1.0"?><!DOCTYPE D '
                                                                   '[<!ENTITY e SYSTEM "file:///etc/passwd">]><DOC><IMAGE '
                                                                   'name="&e;" width="9" height="9"/></DOC>'})),
        "ora zip bomb stack.xml": ("ora", lambda p: zip_members(p, {"stack.xml": b" " * (200 << 20)})),
        "ora layer PNG header 100000²": ("ora", lambda p: ora_doc(p, ora_layer("a"), {"data/a.png": bytes(big_png_header)})),
        "ora document 300000²": ("ora", lambda p: ora_doc(p, ora_layer("a"), {"data/a.png": png}, w=300000, h=300000)),
        "kra document 300000²": ("kra", lambda p: kra_doc(p, "", {}, w=300000, h=300000)),
        "kra tiles over 300000²": ("kra", lambda p: kra_doc(
            p, '<layer name="a" filename="a" nodetype="paintlayer" visible="1" x="0" y="0"/>',
            {"d/layers/a": b"VERSION 2\nTILEWIDTH 64\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA 2\n0,0,LZF,2\n\x00\x00"
                           b"299968,299968,LZF,2\n\x00\x00"})),
        "kra tile count 10^9": ("kra", lambda p: kra_doc(
            p, '<layer name="a" filename="a" nodetype="paintlayer" visible="1" x="0" y="0"/>',
            {"d/layers/a": b"VERSION 2\nTILEWIDTH 64\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA 1000000000\n"})),
        "kra tile 2048 px wide": ("kra", lambda p: kra_doc(
            p, '<layer name="a" filename="a" nodetype="paintlayer" visible="1" x="0" y="0"/>',
            {"d/layers/a": b"VERSION 2\nTILEWIDTH 2048\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA 0\n"})),
        "kra LZF back-reference before the start": ("kra", lambda p: kra_doc(
            p, '<layer name="a" filename="a" nodetype="paintlayer" visible="1" x="0" y="0"/>',
            {"d/layers/a": b"VERSION 2\nTILEWIDTH 64\nTILEHEIGHT 64\nPIXELSIZE 4\nDATA 1\n0,0,LZF,4\n\x01\xe0\xff\xff"})),
        "ora not a zip": ("ora", lambda p: b"<image/>"),
        "kra a zip without maindoc.xml": ("kra", lambda p: zip_members(p, {"x": "y"})),
        "ora stack.xml not XML": ("ora", lambda p: zip_members(p, {"stack.xml": "<<<"})),
        "ora stack.xml root not image": ("ora", lambda p: zip_members(p, {"stack.xml": "<svg/>"})),
        "ora layer PNG is text": ("ora", lambda p: ora_doc(p, ora_layer("a"), {"data/a.png": b"not a png"})),
        "ora layer PNG missing": ("ora", lambda p: ora_doc(p, ora_layer("a"), {})),
    }
    for name, (ext, make) in zips.items():
        cases.append(Case(f"init {name}", "held", init(f"{{d}}/in/z.{ext}"), setup=[data(f"in/z.{ext}", make)],
                          outputs=OUT_S, renders=("out/S.json",),
                          checks=[no_entity("out/S.json", "root:")]))
    # every bad stiffness file, hinge, patch and strength value: a scene of the char with that edit, rendered
    bw, bh = artfiles.part("blueShirt1.png").shape[1::-1]
    stiff = {
        "missing": None, "a FIFO": "fifo", "/dev/zero": "/dev/zero", "a folder": "dir", "another size": "small",
        "text": "text", "empty": "empty", "a truncated PNG": "cut", "16-bit grey": "grey16", "a link loop": "loop",
        "a link outside": "../outside/precious.txt", "a PNG header 100000²": "bomb", "the scene itself": "S.json",
    }
    for what, kind in stiff.items():
        cases.append(Case(f"render: stiffness file {what}", "held", ["render", "{d}/out/S.json", "-o", "{d}/out/r.png"],
                          setup=[base("psd"), stiffness_setup(kind, bw, bh, bytes(big_png_header))], outputs=("out/r.png",)))
    links = {
        "hinge nan": {"points": [["nan", 0]]}, "hinge outside": {"points": [[-500, -500]]},
        "hinge 1e400": {"points": [[1e400, 0]]}, "hinge a string": {"points": "x"},
        "patch of 2 points": {"polygons": [[[150, 230], [160, 230]]]},
        "patch of 1001 points": {"polygons": [[[150 + k % 7, 230 + k % 5] for k in range(1001)]]},
        "patch nan": {"polygons": [[["nan", 0], [1, 0], [1, 1]]]}, "patch outside": {"polygons": [[[-9, -9], [-8, -9], [-8, -8]]]},
        "strength -1": {"strength": -1}, "strength 2": {"strength": 2}, "strength nan": {"strength": "nan"},
        "strength 'x'": {"strength": "x"}, "strength 1e-300": {"strength": 1e-300}, "strength 0": {"strength": 0},
    }
    for what, extra in links.items():
        cases.append(Case(f"render: link {what}", "held", ["render", "{d}/out/S.json", "-o", "{d}/out/r.png"],
                          setup=[base("psd"), link_edit(extra)], outputs=("out/r.png",)))
    cases.append(Case("app open: char.psd (held)", "held", script=APP.format(art="out/char.psd"),
                      setup=[copy("in/char.psd", "out/char.psd")], outputs=("out/char.json", "out/char-layers", "out/char-layers/*"),
                      renders=("out/char.json",), expect_ok=True))
    cases.append(Case("app open twice: char.kra (held)", "held",
                      script=APP.format(art="out/char.kra") + "    opening.preload(D + '/out/char.kra')\n",
                      setup=[copy("in/char.kra", "out/char.kra")],
                      outputs=("out/char.json*", "out/char-layers", "out/char-layers/*", "out/char*.json"),
                      renders=("out/char.json",), expect_ok=True))
    for fmt in FORMATS:
        cases.append(Case(f"init {fmt} --pins auto --links auto (held)", "held", init(f"{{d}}/in/char.{fmt}", "{d}/out/S.json", *AUTO),
                          outputs=OUT_S, renders=("out/S.json",), expect_ok=True))
    for ext in ("html", "glb", "spine.json", "gif"):
        cases.append(Case(f"animate .{ext} (held)", "held", ["animate", "{d}/in/anim.json", "-o", f"{{d}}/out/a.{ext}"],
                          outputs=(f"out/a.{ext}", "out/a.spine.*"), expect_ok=True))
    return cases


def symlink_member(p):
    info = zipfile.ZipInfo("data/a.png")
    info.external_attr = (0o120777 << 16)
    with zipfile.ZipFile(p, "w") as z:
        z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
        z.writestr("stack.xml", '<image w="30" h="30"><stack>' + ora_layer("a") + "</stack></image>")
        z.writestr(info, "../../../outside/precious.txt")


def zip_members(p, members):
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for k, v in members.items():
            z.writestr(k, v)


def stiffness_setup(kind, bw, bh, bomb):
    def f(d):
        out = os.path.join(d, "out")
        p = os.path.join(out, "S-layers", "stiff.png")
        rel = "S-layers/stiff.png"
        if kind is None:
            pass
        elif kind == "fifo":
            os.mkfifo(p)
        elif kind == "dir":
            os.mkdir(p)
        elif kind == "small":
            open(p, "wb").write(artfiles.png_bytes(solid(bw, bh // 2)))
        elif kind == "text":
            open(p, "w").write("not a png")
        elif kind == "empty":
            open(p, "wb").close()
        elif kind == "cut":
            open(p, "wb").write(artfiles.png_bytes(solid(bw, bh))[:60])
        elif kind == "grey16":
            from PIL import Image
            Image.fromarray(np.full((bh, bw), 40000, np.uint16)).save(p)
        elif kind == "loop":
            os.symlink("stiff.png", p)
        elif kind == "bomb":
            open(p, "wb").write(bomb)
        elif kind == "S.json":
            rel = "S.json"
        elif kind.startswith("/"):
            rel = kind
        else:
            rel = "../outside/precious.txt"
        doc = json.load(open(os.path.join(out, "S.json")))
        next(L for L in doc["layers"] if L["name"] == "body")["stiffness"] = {"file": rel}
        json.dump(doc, open(os.path.join(out, "S.json"), "w"))
    return f


def link_edit(extra):
    def f(d):
        p = os.path.join(d, "out", "S.json")
        doc = json.load(open(p))
        lk = next(k for k in doc["links"] if set(k["layers"]) == {"body", "neck"} or "body" in k["layers"])
        for k, v in extra.items():
            lk[k] = float(v) if v in ("nan",) else v
        text = json.dumps(doc).replace('"nan"', "NaN").replace("1e400", "1e999")
        open(p, "w").write(text.replace("Infinity", "1e999"))
    return f


#: a body run by the API cases: ``s`` the animated psd scene (in/anim.json), PIN the arm pin its pose
#: moves, SPIN a body pin in no pose, LINK a linked pair, BW x BH the body layer image's size
API = """
import json, os, sys, numpy as np, puppet
from puppet.errors import SceneError
D = sys.argv[1]
try:
    s = puppet.load_scene(D + '/in/anim.json')
    PIN = next(p['name'] for p in s.to_dict()['pins'] if p['layer'] == 'arm_front')
    SPIN = next(p['name'] for p in s.to_dict()['pins'] if p['layer'] == 'body')  # in no pose: may become starch
    LINK = s.to_dict()['links'][0]['layers']
    from PIL import Image
    BW, BH = Image.open(D + '/in/anim-layers/body.png').size
    {body}
except SceneError as e:
    print(f"puppet: error: {{e}}", file=sys.stderr); sys.exit(2)
"""

#: the app's open path, as ``puppet app ART`` runs it before a window opens (no GL)
APP = """
import sys
from puppet.errors import SceneError
from puppet.app.model import opening
D = sys.argv[1]
try:
    opening.preload(D + '/{art}')
"""
APP_END = """
except SceneError as e:
    print(f"puppet: error: {e}", file=sys.stderr); sys.exit(2)
"""


# -- running and judging ------------------------------------------------------------------------------
def _cap(cap=MEMORY_CAP):
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    os.setsid()
    # a campaign started in the background (``... &``) has SIGINT ignored, and a child would
    # inherit that: Python then installs no KeyboardInterrupt handler and the SIGINT cases test nothing
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def child_env(d):
    env = dict(os.environ, PYTHONPATH=ROOT, TMPDIR=os.path.join(d, "tmp"))
    env.pop("DISPLAY", None)
    return env


def run_case(case: Case, template: str, timeout: float) -> dict:
    d = tempfile.mkdtemp(prefix="campaign-")
    res = {"name": case.name, "section": case.section, "hang": False, "rc": None, "err": "", "wrong": [],
           "seconds": 0.0}
    try:
        shutil.copytree(template, d, symlinks=True, dirs_exist_ok=True)
        for f in case.setup:
            f(d)
        before = snapshot(d)
        script = case.script
        if script is not None and script.startswith(APP.split("{")[0]):
            script += APP_END
        t0 = time.monotonic()
        ran = run_child(case_command(PY, script, case.argv, d), timeout=case.timeout or timeout,
                        signal_after=case.signal_after, env=child_env(d), cwd=d,
                        preexec_fn=lambda: _cap(case.memory_cap))
        res.update(rc=ran.rc, hang=ran.hang, err=ran.err, seconds=time.monotonic() - t0)
        time.sleep(0.05)
        after = snapshot(d)
        judge(case, d, before, after, res)
        if (res["rc"] == 0 or res["whole"]) and not res["hang"]:
            for scene in case.renders:
                if os.path.exists(os.path.join(d, scene)):
                    why = render_ok(d, scene, timeout)
                    if why:
                        res["wrong"].append(why)
        res["bad"] = any(res[k] for k in CATEGORIES)
        return res
    except Exception as e:  # a setup that failed: reported as such, not as a finding
        res.update(setup_error=f"{type(e).__name__}: {e}", bad=True, **{k: False for k in CATEGORIES})
        return res
    finally:
        unmount_under(d)
        shutil.rmtree(d, ignore_errors=True)


def judge(case: Case, d: str, before: dict, after: dict, res: dict) -> None:
    def is_output(rel):
        return any(fnmatch.fnmatch(rel, pat) for pat in case.outputs)
    err, rc, hang = res["err"], res["rc"], res["hang"]
    sig_ok = set()
    if case.signal_after:
        sig_ok = {130, -case.signal_after[0], 128 + case.signal_after[0]}
    res["memory"] = not hang and (any(w in err for w in MEMORY_WORDS) or rc == -signal.SIGKILL)
    crashed = not hang and rc not in (0, 2, 5) and rc not in sig_ok
    res["traceback"] = not res["memory"] and ("Traceback" in err or crashed)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    warned = any("Warning:" in ln for ln in lines)
    res["messy"] = not res["traceback"] and not res["memory"] and (
        (rc == 2 and not (len(lines) == 1 and lines[0].startswith("puppet: error: "))) or warned)
    if rc == 5:
        res["wrong"].append("a bad argument was accepted")
    if case.expect_ok and rc not in (0, None) and not res["traceback"]:
        res["wrong"].append("a valid file was refused: " + (lines[-1][:160] if lines else ""))
    forced = "--force" in (case.argv or [])
    changed = sorted(p for p in set(before) | set(after) if before.get(p) != after.get(p))
    # a stop that came after the output was committed (signals are held while it is) leaves
    # the whole output: only outputs changed, no temporary, the scenes to render all there
    res["whole"] = rc in sig_ok and bool(changed) and bool(case.renders) and all(
        is_output(p) and not p.endswith(".tmp") for p in changed) and all(
        os.path.exists(os.path.join(d, r)) for r in case.renders)
    ok = rc in (0, 5) or res["whole"]  # 5: an API script that got through a call that should have been refused
    res["outside"] = [] if hang else [p for p in changed if not ok or (not is_output(p) and (
        p not in before or p.split(os.sep)[0] in ("outside", "tmp")))]
    res["modified"] = [] if hang else [p for p in changed if p in before and p.split(os.sep)[0] not in ("outside", "tmp")
                                       and (not is_output(p) or (p in case.protect and not forced))]
    for check in case.checks:
        why = check(d, res, before, after)
        if why:
            res["wrong"].append(why)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-k", default="", help="only cases whose name holds this")
    ap.add_argument("-j", type=int, default=2, help="cases at a time")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    ap.add_argument("--section", default="", help="only the cases of these issue sections (1-9, held; comma-separated)")
    ap.add_argument("--list", action="store_true", help="list the cases and stop")
    ap.add_argument("-v", action="store_true", help="print every case")
    args = ap.parse_args()
    template = tempfile.mkdtemp(prefix="campaign-template-")
    try:
        t0 = time.monotonic()
        facts = build_template(template)
        cases = (section1() + section2() + section3(facts) + section4(facts) + section5() + section6() + section7()
                 + section8() + section9() + held())
        cases = [c for c in cases if args.k in c.name and (not args.section or c.section in args.section.split(","))]
        if args.list:
            for c in cases:
                print(f"[{c.section}] {c.name}")
            print(f"{len(cases)} cases")
            return 0
        # the slow ones first, so that two workers end together
        order = sorted(cases, key=lambda c: c.section not in ("5",))
        done = []

        def one(c):
            r = run_case(c, template, args.timeout)
            done.append(r)
            if len(done) % 50 == 0:
                print(f"... {len(done)}/{len(order)} cases, {time.monotonic() - t0:.0f} s", file=sys.stderr, flush=True)
            return r
        with ThreadPoolExecutor(args.j) as pool:
            results = list(pool.map(one, order))
    finally:
        shutil.rmtree(template, ignore_errors=True)
    return report(results, time.monotonic() - t0, args.v)


def report(results, seconds, verbose) -> int:
    sections = ["1", "2", "3", "4", "5", "6", "7", "8", "9", "held"]
    results.sort(key=lambda r: (sections.index(r["section"]), r["name"]))
    for r in results:
        if not (r["bad"] or verbose):
            continue
        if r.get("setup_error"):
            print(f"SETUP [{r['section']}] {r['name']}: {r['setup_error']}")
            continue
        flags = [k for k in CATEGORIES if r[k]]
        print(f"{'BAD ' if r['bad'] else 'ok  '}[{r['section']}] {r['name']}: rc={r['rc']} {' '.join(flags)} "
              f"({r['seconds']:.1f} s)")
        for k in ("outside", "modified"):
            if r[k]:
                print(f"     {k}: {r[k][:3]}{' ...' if len(r[k]) > 3 else ''}")
        for w in r["wrong"]:
            print(f"     wrong: {w}")
        if r["err"].strip():
            print("     stderr: " + r["err"].strip().splitlines()[-1][:200])
    n = len(results)
    count = {k: sum(bool(r[k]) for r in results) for k in CATEGORIES}
    per = Counter(r["section"] for r in results if r["bad"])
    total = Counter(r["section"] for r in results)
    print("\nper section (bad/cases; categories):")
    for sec in sections:
        if total[sec]:
            cats = Counter(k for r in results if r["section"] == sec for k in CATEGORIES if r[k])
            print(f"  {sec:>4}: {per[sec]}/{total[sec]}  " + " ".join(f"{k} {cats[k]}" for k in CATEGORIES if cats[k]))
    setup = sum(bool(r.get("setup_error")) for r in results)
    print(f"cases {n} in {seconds:.0f} s, bad {sum(bool(r['bad']) for r in results)}"
          + (f", setup errors {setup}" if setup else ""))
    print(f"{count['traceback']} tracebacks, {count['hang']} hangs, {count['outside']} writes outside, "
          f"{count['modified']} user files modified, {count['memory']} memory blow-ups, {count['messy']} messy errors, "
          f"{count['wrong']} silently wrong")
    return 1 if any(r["bad"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
