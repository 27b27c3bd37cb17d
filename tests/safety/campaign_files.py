"""Attack campaign on the file surfaces of issue 20 (not collected by pytest: run it).

    .venv/bin/python tests/safety/campaign_files.py [-k WORD] [-j 2] [--timeout 90]

Each case runs in its own temporary folder (``in/`` inputs, ``out/`` outputs, ``outside/``
files nobody names), as a subprocess under a timeout and an address-space cap: the real
CLI (``python -m puppet ...``) or a short API script (save, autosave). Every file, link,
FIFO and folder is recorded before and after (bytes of regular files; nothing is read
through a link or from a FIFO), and each case is judged:

- traceback: ``Traceback`` on stderr, or an exit status other than 0 and 2;
- hang: the timeout expired;
- messy error: exit 2 without exactly one ``puppet: error:`` line;
- silent: a truncated clip re-posed with exit 0 and no warning line;
- input modified: a file that existed before changed or went away (outputs the case
  names are allowed to change);
- write outside -o: anything new or changed that is not an output the case names, or
  anything at all left behind by a run that failed.

Prints one line per bad case and the counts.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)
from tests import fstree  # noqa: E402
from tests.safety.child import case_command, run_child  # noqa: E402
MEMORY_CAP = 6 << 30  # bytes of address space per case
PY = sys.executable


@dataclass
class Case:
    name: str
    argv: list[str] | None = None  # CLI arguments, "{d}" is the case folder
    script: str | None = None  # or a Python snippet run with D = the case folder
    setup: list = field(default_factory=list)  # callables f(d) run after the template is copied
    outputs: tuple[str, ...] = ()  # paths under {d} the case may create or change
    env: dict | None = None
    warn: str | None = None  # a success must say this on stderr (a truncated clip)


# -- the template every case starts from ---------------------------------------------------------------
def build_template(t: str) -> None:
    import av
    import numpy as np

    from tests.conftest import bar_image, bar_scene, write_rgba
    from tests.video.video_helpers import video_scene, write_folder_clip, frame, W, H

    for sub in ("in", "out", "outside"):
        os.makedirs(os.path.join(t, sub))
    i = os.path.join(t, "in")
    write_rgba(os.path.join(i, "bar.png"), bar_image())
    s = bar_scene()
    s["animation"] = {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 0.3, "pose": "bend"}]}
    json.dump(s, open(os.path.join(i, "scene.json"), "w"))
    shutil.copy(os.path.join(ROOT, "assets", "horse", "horse.png"), os.path.join(i, "horse.png"))
    with open(os.path.join(t, "outside", "precious.txt"), "w") as f:
        f.write("not yours\n")

    def clip(path, n, codec="libx264", pix="yuv420p", size=(W, H), **opts):
        with av.open(path, "w", options=opts) as box:
            st = box.add_stream(codec, rate=12)
            st.width, st.height, st.pix_fmt = size[0], size[1], pix
            for k in range(n):
                img = frame(k) if size == (W, H) else np.full((size[1], size[0], 3), 50, np.uint8)
                for p in st.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                    box.mux(p)
            for p in st.encode():
                box.mux(p)
        return open(path, "rb").read()

    mp4 = clip(os.path.join(i, "walk.mp4"), 12, movflags="faststart")
    avi = clip(os.path.join(i, "walk.avi"), 12, codec="mjpeg", pix="yuvj420p")
    for frac in (0.3, 0.6, 0.8, 0.95):
        open(os.path.join(i, f"cut{int(frac * 100)}.mp4"), "wb").write(mp4[:int(len(mp4) * frac)])
        open(os.path.join(i, f"cut{int(frac * 100)}.avi"), "wb").write(avi[:int(len(avi) * frac)])
    clip(os.path.join(i, "wide.avi"), 1, codec="mjpeg", pix="yuvj420p", size=(20000, 64))
    open(os.path.join(i, "junk.mp4"), "wb").write(b"\x00\x00\x00\x18ftypmp42" + b"junk" * 100)
    open(os.path.join(i, "empty.mp4"), "wb").close()
    write_folder_clip(os.path.join(i, "frames"), n=4)
    for src in ["walk.mp4", "walk.avi", "frames", "junk.mp4", "empty.mp4", "wide.avi"] + \
            [f"cut{p}.{e}" for p in (30, 60, 80, 95) for e in ("mp4", "avi")]:
        name = "v_" + src.replace(".", "_") + ".json"
        json.dump(video_scene(src), open(os.path.join(i, name), "w"))
    json.dump(video_scene("walk.mp4", video={"start": 11}), open(os.path.join(i, "v_late.json"), "w"))


def fifo(rel):
    return lambda d: os.mkfifo(os.path.join(d, rel))


def link(target, rel):
    return lambda d: os.symlink(target.format(d=d), os.path.join(d, rel))


def write(rel, data):
    def f(d):
        p = os.path.join(d, rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "wb") as fh:
            fh.write(data if isinstance(data, bytes) else data.encode())
    return f


def full_disk(rel="out/full", size="64k"):
    """A tmpfs mounted at ``rel`` and filled to the last byte (root only; unmounted after the case)."""
    from tests.cli.outputs_helpers import fill

    def f(d):
        where = os.path.join(d, rel)
        os.makedirs(where, exist_ok=True)
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", where], check=True,
                       capture_output=True)
        fill(where)
    return f


def unmount_under(d: str) -> None:
    with open("/proc/mounts") as f:
        points = [line.split()[1] for line in f]
    for p in sorted((p for p in points if p.startswith(d + "/")), reverse=True):
        subprocess.run(["umount", "-l", p], capture_output=True)


def full_disk_cases() -> list[Case]:
    s, v, h = "{d}/in/scene.json", "{d}/in/v_walk_mp4.json", "{d}/in/horse.png"
    f = "{d}/out/full"
    cli = {
        "render": ["render", s, "-o", f + "/r.png"],
        "mesh": ["mesh", s, "-o", f + "/m.json"],
        "animate gif": ["animate", s, "-o", f + "/a.gif"],
        "animate frames": ["animate", s, "-o", f + "/frames/"],
        "animate sheet": ["animate", s, "-o", f + "/sheet.png"],
        "init": ["init", h, "-o", f + "/s.json"],
        "video mp4": ["video", v, "--pose", "wave", "-o", f + "/o.mp4"],
        "video tracks": ["video", v, "--pose", "wave", "-o", "{d}/out/o.mp4", "--tracks", f + "/t.json"],
    }
    cases = [Case(f"full disk {name}", argv, setup=[full_disk()]) for name, argv in cli.items()]
    paint = "    s = puppet.load_scene(D + '/in/scene.json'); s.set_mask_pixels('bar', np.random.default_rng(0).random((40, 120)) > .5)\n"
    cases.append(Case("full disk api save painted", script=SAVE.format(body=paint + "    s.save(D + '/out/full/s.json')\n"),
                      setup=[full_disk()]))
    return cases


def scene_with(rel, edit):
    """A copy of in/scene.json (the bar) at ``rel`` with ``edit(doc)`` applied."""
    def f(d):
        doc = json.load(open(os.path.join(d, "in", "scene.json")))
        edit(doc)
        with open(os.path.join(d, rel), "w") as fh:
            json.dump(doc, fh)
    return f


def set_path(where, value):
    def edit(doc):
        if where == "image":
            doc["layers"][0]["image"] = value
        elif where == "mask":
            doc["layers"][0]["mask"] = {"file": value}
        elif where == "source":
            doc["source"] = value
            doc["layers"].append({"name": "copy", "mask": {"rect": [0, 0, 9, 9]}})
        else:
            doc["background"] = value
    return edit


# -- the cases ------------------------------------------------------------------------------------------
def video_cases() -> list[Case]:
    out = []
    scenes = ["walk_mp4", "walk_avi", "frames", "junk_mp4", "empty_mp4", "wide_avi", "late"] + \
        [f"cut{p}_{e}" for p in (30, 60, 80, 95) for e in ("mp4", "avi")]
    for sc in scenes:
        for o, outs in (("{d}/out/o.mp4", ("out/o.mp4",)), ("{d}/out/f/", ("out/f",))):
            out.append(Case(f"video {sc} -> {os.path.basename(o.rstrip('/'))} + tracks",
                            ["video", f"{{d}}/in/v_{sc}.json", "--pose", "wave", "-o", o,
                             "--tracks", "{d}/out/t.json"], outputs=outs + ("out/t.json",),
                            warn="warning" if sc.startswith("cut") else None))
    v = "{d}/in/v_walk_mp4.json"
    base = ["video", v, "--pose", "wave"]
    odd = [
        ("-o the source", ["-o", "{d}/in/walk.mp4"], ()),
        ("-o a link to the source", ["-o", "{d}/out/l.mp4"], (), [link("{d}/in/walk.mp4", "out/l.mp4")]),
        ("-o a FIFO", ["-o", "{d}/out/p.mp4"], (), [fifo("out/p.mp4")]),
        ("-o /dev/null.mp4", ["-o", "/dev/null.mp4"], ()),
        ("-o /proc/self/x.mp4", ["-o", "/proc/self/x.mp4"], ()),
        ("-o in/ (holds inputs)", ["-o", "{d}/in/"], ()),
        ("-o folder with a subfolder frame", ["-o", "{d}/out/f/"], (), [write("out/f/frame_00000.png/keep.txt", "x")]),
        ("--tracks the scene", ["-o", "{d}/out/o.mp4", "--tracks", v], ()),
        ("--tracks a folder", ["-o", "{d}/out/o.mp4", "--tracks", "{d}/out/t.json"], (),
         [lambda d: os.mkdir(os.path.join(d, "out", "t.json"))]),
        ("--tracks = -o", ["-o", "{d}/out/o.mp4", "--tracks", "{d}/out/o.mp4"], ()),
        ("--tracks FIFO", ["-o", "{d}/out/o.mp4", "--tracks", "{d}/out/t.json"], (), [fifo("out/t.json")]),
        ("--tracks in a missing folder", ["-o", "{d}/out/o.mp4", "--tracks", "{d}/nope/t.json"], ()),
        ("--anchors missing", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/none.json"], ()),
        ("--anchors FIFO", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/a.json"], (), [fifo("in/a.json")]),
        ("--anchors /dev/zero", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/a.json"], (),
         [link("/dev/zero", "in/a.json")]),
        ("--anchors deep", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/a.json"], (),
         [write("in/a.json", "[" * 100000 + "]" * 100000)]),
        ("--anchors key ²", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/a.json"], (),
         [write("in/a.json", '{"\u00b2": {"hand": [1, 2]}}')]),
        ("--anchors 5000 digits", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/a.json"], (),
         [write("in/a.json", '{"' + "9" * 5000 + '": {}}')]),
        ("--anchors huge coordinate", ["-o", "{d}/out/o.mp4", "--anchors", "{d}/in/a.json"], (),
         [write("in/a.json", '{"3": {"hand": [1e308, 2]}}')]),
        ("--anchors = -o", ["-o", "{d}/in/a.json", "--anchors", "{d}/in/a.json"], (),
         [write("in/a.json", '{"3": {"hand": [100, 40]}}')]),
        ("--from 99", ["-o", "{d}/out/o.mp4", "--from", "99"], ()),
        ("--to -1", ["-o", "{d}/out/o.mp4", "--to", "-1"], ()),
        ("--from 5000 digits", ["-o", "{d}/out/o.mp4", "--from", "9" * 5000], ()),
        ("-o .avi", ["-o", "{d}/out/o.avi"], ()),
    ]
    for name, extra, outs, *setup in odd:
        out.append(Case(f"video {name}", base + extra, outputs=outs, setup=setup[0] if setup else []))
    return out


def animate_cases() -> list[Case]:
    s = "{d}/in/scene.json"
    out = []
    for bg in ("rgb(300,0,0)", "hsl(400,200%,50%)", "rgb(50%,200%,0%)", "hsl(0,0%,150%)", "rgba(0,0,0,2)",
               "#zzz", "rgb(1e400,0,0)", "hsla(0,0%,0%,5)", "\x01", "white" * 1000):
        out.append(Case(f"animate --background {bg[:20]!r}", ["animate", s, "-o", "{d}/out/a.gif", "--background", bg],
                        outputs=("out/a.gif",)))
    for fps in ("0", "-1", "nan", "inf", "1e400", "1000000"):
        out.append(Case(f"animate --fps {fps}", ["animate", s, "-o", "{d}/out/a.gif", "--fps", fps], outputs=("out/a.gif",)))
    keys = {
        "fps 0": {"fps": 0, "keys": [{"time": 0, "pose": "rest"}]},
        "time 1e300": {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 1e300, "pose": "bend"}]},
        "negative time": {"fps": 10, "keys": [{"time": -5, "pose": "rest"}, {"time": 0.2, "pose": "bend"}]},
        "unknown pose": {"fps": 10, "keys": [{"time": 0, "pose": "nope"}]},
        "same time twice": {"fps": 10, "keys": [{"time": 0, "pose": "rest"}, {"time": 0, "pose": "bend"}]},
        "key not an object": {"fps": 10, "keys": [1, 2]},
        "keys a string": {"fps": 10, "keys": "xx"},
        "ease junk": {"fps": 10, "keys": [{"time": 0, "pose": "rest", "ease": "\u0000"}, {"time": 1, "pose": "bend"}]},
        "20000 keys": {"fps": 10, "keys": [{"time": i / 100, "pose": "rest"} for i in range(20000)]},
    }
    for name, anim in keys.items():
        out.append(Case(f"animate keys {name}", ["animate", "{d}/in/k.json", "-o", "{d}/out/a.gif"],
                        setup=[scene_with("in/k.json", lambda doc, a=anim: doc.__setitem__("animation", a))],
                        outputs=("out/a.gif",)))
    outs = [
        ("folder with a subfolder named like a frame", "{d}/out/f/", [write("out/f/frame_00000.png/keep.txt", "x")]),
        ("folder with a link named like a frame", "{d}/out/f/",
         [lambda d: os.makedirs(os.path.join(d, "out", "f")), link("{d}/outside/precious.txt", "out/f/frame_00001.png")]),
        ("folder holding other files", "{d}/out/f/", [write("out/f/notes.txt", "x")]),
        ("-o = the scene", s, []),
        ("-o = the image", "{d}/in/bar.png", []),
        ("-o in/ (holds inputs)", "{d}/in/", []),
        ("-o link to the image", "{d}/out/l.png", [link("{d}/in/bar.png", "out/l.png")]),
        ("-o a FIFO", "{d}/out/p.gif", [fifo("out/p.gif")]),
        ("-o /dev/full.gif", "/dev/full.gif", []),
        ("-o /proc/self/a.gif", "/proc/self/a.gif", []),
        ("-o a folder named a.gif", "{d}/out/a.gif", [lambda d: os.mkdir(os.path.join(d, "out", "a.gif"))]),
        ("-o frames over old frames", "{d}/out/f/", [write("out/f/frame_00000.png", b"old")]),
        ("-o missing folder", "{d}/nope/a.gif", []),
        ("-o .xyz", "{d}/out/a.xyz", []),
    ]
    for name, o, setup in outs:
        allowed = () if o.startswith("/") or "{d}/in" in o or "nope" in o else (o.replace("{d}/", "").rstrip("/"),)
        if "link" in name and "frame" not in name:
            allowed = ()
        out.append(Case(f"animate {name}", ["animate", s, "-o", o], setup=setup, outputs=allowed))
    return out


def init_cases() -> list[Case]:
    h = "{d}/in/horse.png"
    o = "{d}/out/s.json"
    outs = ("out/s.json", "out/s-mask.png")
    cases = []
    for rect in ("0,0,400,328", "-10,-10,9999,9999", "1,1,398,326", "0,0,2,2", "0,0,1,1", "399,327,5,5",
                 "500,500,10,10", "0,0,1e9,1e9", "nan,0,1,1"):
        cases.append(Case(f"init --grabcut {rect}", ["init", h, "-o", o, "--grabcut", rect], outputs=outs))
    cases += [
        Case("init mask through a link outside", ["init", h, "-o", o],
             setup=[link("{d}/outside/precious.txt", "out/s-mask.png")]),
        Case("init mask through a dangling link", ["init", h, "-o", o], setup=[link("{d}/outside/new.png", "out/s-mask.png")]),
        Case("init mask is a folder", ["init", h, "-o", o], setup=[lambda d: os.mkdir(os.path.join(d, "out", "s-mask.png"))]),
        Case("init mask is a FIFO", ["init", h, "-o", o], setup=[fifo("out/s-mask.png")]),
        Case("init -o beside the picture", ["init", h, "-o", "{d}/in/horse.json"],
             outputs=("in/horse.json", "in/horse-mask.png")),
        Case("init -o = picture", ["init", h, "-o", "{d}/in/horse.png"]),
        Case("init picture FIFO", ["init", "{d}/in/p.png", "-o", o], setup=[fifo("in/p.png")]),
        Case("init picture /dev/zero", ["init", "/dev/zero", "-o", o]),
        Case("init picture /proc/self/mem", ["init", "/proc/self/mem", "-o", o]),
        Case("init picture /proc/self/environ", ["init", "/proc/self/environ", "-o", o]),
        Case("init picture empty", ["init", "{d}/in/e.png", "-o", o], setup=[write("in/e.png", b"")]),
        Case("init picture folder", ["init", "{d}/in", "-o", o]),
        Case("init -o FIFO", ["init", h, "-o", o], setup=[fifo("out/s.json")]),
        Case("init -o read-only folder", ["init", h, "-o", o], setup=[lambda d: os.chmod(os.path.join(d, "out"), 0o555)],
             outputs=outs),  # root writes there anyway
        Case("init --threshold 300", ["init", h, "-o", o, "--threshold", "300"], outputs=outs),
        Case("init --pins auto", ["init", h, "-o", o, "--pins", "auto"], outputs=outs),
    ]
    return cases


def path_cases() -> list[Case]:
    bad = {"NUL": "x\u0000y.png", "/proc/self/mem": "/proc/self/mem", "/dev/zero": "/dev/zero",
           "/dev/urandom": "/dev/urandom", "FIFO": "fifo.png", "folder": ".", "loop": "loop.png",
           "long": "a/" * 3000 + "x.png", "../../etc/passwd": "../../../../../../etc/passwd",
           "empty": "e.png", "self": "k.json"}
    setup = [fifo("in/fifo.png"), link("{d}/in/loop.png", "in/loop.png"), write("in/e.png", b"")]
    cases = []
    for what, value in bad.items():
        for where in ("image", "mask", "source", "background"):
            for cmd in (["check", "{d}/in/k.json"], ["render", "{d}/in/k.json", "-o", "{d}/out/r.png"],
                        ["mesh", "{d}/in/k.json", "-o", "{d}/out/m.json"]):
                cases.append(Case(f"{cmd[0]} {where} = {what}", cmd,
                                  setup=setup + [scene_with("in/k.json", set_path(where, value))],
                                  outputs=("out/r.png", "out/m.json")))
    return cases


SAVE = """
import json, os, sys, numpy as np, puppet
from puppet.errors import SceneError
D = sys.argv[1]
try:
{body}
except SceneError as e:
    print(f"puppet: error: {{e}}", file=sys.stderr); sys.exit(2)
"""


def save_cases() -> list[Case]:
    paint = "    s = puppet.load_scene(D + '/in/scene.json'); s.set_mask_pixels('bar', np.ones((40, 120), bool))\n"
    bodies = {
        "save painted into symlinked folder, load both":
            (paint + "    s.save(D + '/out/l/s.json')\n"
             "    for p in (D + '/out/l/s.json', D + '/out/real/s.json'): puppet.load_scene(p).render()\n",
             [lambda d: os.mkdir(os.path.join(d, "out", "real")), link("{d}/out/real", "out/l")],
             ("out/real/s.json", "out/real/s.files")),
        "save over the layer image": (paint + "    s.save(D + '/in/bar.png')\n", [], ()),
        "save painted into read-only folder":
            (paint + "    s.save(D + '/out/s.json')\n", [lambda d: os.chmod(os.path.join(d, "out"), 0o555)],
             ("out/s.json", "out/s.files")),  # root writes there anyway
        "save with s.files a link outside":
            (paint + "    s.save(D + '/out/s.json')\n", [link("{d}/outside", "out/s.files")], ()),
        "save with s.files a file":
            (paint + "    s.save(D + '/out/s.json')\n", [write("out/s.files", "x")], ()),
        "save with a link in s.files":
            (paint + "    s.save(D + '/out/s.json'); puppet.load_scene(D + '/out/s.json').render()\n",
             [lambda d: os.mkdir(os.path.join(d, "out", "s.files"))] +
             [lambda d: [os.symlink(os.path.join(d, "outside", "precious.txt"), os.path.join(d, "out", "s.files", n))
                         for n in ("bar-mask-" + "0" * 12 + ".png",)]],
             ("out/s.json", "out/s.files")),
        "save to a FIFO": (paint + "    s.save(D + '/out/p.json')\n", [fifo("out/p.json")], ()),
        "autosave.remove beside an image named so":
            ("    from puppet.app import autosave\n    autosave.remove(D + '/in/scene.json')\n",
             [lambda d: shutil.copy(os.path.join(d, "in", "bar.png"), os.path.join(d, "in", "scene.autosave.json"))], ()),
        "autosave.write over an image named so":
            ("    from puppet.app import autosave\n    s = puppet.load_scene(D + '/in/scene.json')\n"
             "    autosave.write(s)\n",
             [lambda d: shutil.copy(os.path.join(d, "in", "bar.png"), os.path.join(d, "in", "scene.autosave.json"))], ()),
        "autosave.write through a link":
            ("    from puppet.app import autosave\n    s = puppet.load_scene(D + '/in/scene.json')\n"
             "    autosave.write(s)\n", [link("{d}/outside/precious.txt", "in/scene.autosave.json")], ()),
        "autosave.remove a link": ("    from puppet.app import autosave\n    autosave.remove(D + '/in/scene.json')\n",
                                   [link("{d}/outside/precious.txt", "in/scene.autosave.json")], ()),
        "autosave then save: pixels in SCENE.files":
            ("    from puppet.app import autosave\n" + paint.replace("    s =", "    s =", 1) +
             "    autosave.write(s); s.save(D + '/in/scene.json'); autosave.remove(D + '/in/scene.json')\n"
             "    doc = json.load(open(D + '/in/scene.json'))\n"
             "    assert doc['layers'][0]['mask']['file'].startswith('scene.files/'), doc\n",
             [], ("in/scene.json", "in/scene.files", "in/scene.autosave.json", "in/scene.autosave.files")),
    }
    return [Case(f"api {name}", script=SAVE.format(body=body), setup=setup, outputs=outs)
            for name, (body, setup, outs) in bodies.items()]


# -- running and judging ------------------------------------------------------------------------------
def snapshot(top: str) -> dict[str, tuple]:
    """:func:`tests.fstree.snapshot` by absolute path."""
    return {os.path.join(top, rel): v for rel, v in fstree.snapshot(top).items()}


def _cap():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    os.setsid()


def run_case(case: Case, template: str, timeout: float) -> dict:
    d = tempfile.mkdtemp(prefix="campaign-")
    try:
        shutil.copytree(template, d, symlinks=True, dirs_exist_ok=True)
        for f in case.setup:
            f(d)
        before = snapshot(d)
        env = dict(os.environ, PYTHONPATH=ROOT, **(case.env or {}))
        env.pop("DISPLAY", None)
        ran = run_child(case_command(PY, case.script, case.argv, d), timeout=timeout, env=env, cwd=d,
                        preexec_fn=_cap)
        res = {"name": case.name, "hang": ran.hang, "rc": ran.rc, "err": "" if ran.hang else ran.err}
        after = snapshot(d)
        return judge(case, d, before, after, res)
    finally:
        unmount_under(d)
        for dirpath, dirnames, _ in os.walk(d):
            for n in dirnames:
                try:
                    os.chmod(os.path.join(dirpath, n), 0o755)
                except OSError:
                    pass
        shutil.rmtree(d, ignore_errors=True)


def judge(case: Case, d: str, before: dict, after: dict, res: dict) -> dict:
    allowed = [os.path.join(d, o) for o in case.outputs]

    def is_output(p):
        return any(p == a or p.startswith(a + os.sep) for a in allowed)
    err, rc = res["err"], res["rc"]
    res["traceback"] = "Traceback" in err or (rc not in (0, 2) and not res["hang"])
    lines = [ln for ln in err.splitlines() if ln.strip()]
    res["messy"] = rc == 2 and not (len(lines) == 1 and lines[0].startswith("puppet: error: "))
    res["silent"] = rc == 0 and case.warn is not None and case.warn not in err
    changed = {p for p in set(before) | set(after) if before.get(p) != after.get(p)}
    res["modified"] = sorted(p for p in changed if p in before and not is_output(p))
    ok = rc == 0
    res["outside"] = sorted(p for p in changed if p not in before and (not is_output(p) or not ok))
    if not ok:  # a failed run leaves nothing: not even an output it may write
        res["outside"] += sorted(p for p in changed if p in before and is_output(p))
    res["bad"] = res["traceback"] or res["hang"] or res["messy"] or res["silent"] or res["modified"] or res["outside"]
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-k", default="", help="only cases whose name holds this")
    ap.add_argument("-j", type=int, default=2, help="cases at a time")
    ap.add_argument("--timeout", type=float, default=90.0)
    ap.add_argument("-v", action="store_true", help="print every case")
    args = ap.parse_args()
    cases = [c for c in video_cases() + animate_cases() + init_cases() + path_cases() + save_cases()
             + full_disk_cases() if args.k in c.name]
    template = tempfile.mkdtemp(prefix="campaign-template-")
    try:
        build_template(template)
        with ThreadPoolExecutor(args.j) as pool:
            results = list(pool.map(lambda c: run_case(c, template, args.timeout), cases))
    finally:
        shutil.rmtree(template, ignore_errors=True)
    for r in results:
        if r["bad"] or args.v:
            flags = [k for k in ("traceback", "hang", "messy", "silent") if r[k]]
            print(f"{'BAD ' if r['bad'] else 'ok  '}{r['name']}: rc={r['rc']} {' '.join(flags)}"
                  f"{' modified=' + str(r['modified'][:3]) if r['modified'] else ''}"
                  f"{' outside=' + str(r['outside'][:3]) if r['outside'] else ''}")
            if r["bad"] and r["err"]:
                print("     " + r["err"].strip().splitlines()[-1][:200])
    n = len(results)
    print(f"cases {n}, tracebacks {sum(r['traceback'] for r in results)}, hangs {sum(r['hang'] for r in results)}, "
          f"messy errors {sum(r['messy'] for r in results)}, silent truncations {sum(r['silent'] for r in results)}, "
          f"inputs modified {sum(bool(r['modified']) for r in results)}, "
          f"writes outside -o {sum(bool(r['outside']) for r in results)}")
    return 1 if any(r["bad"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
