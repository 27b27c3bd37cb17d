"""The ``puppet`` command: render, animate, mesh, check, init, app, video, batch, retarget, dressroom.

Exit status: 0 success; 2 bad input (one line ``puppet: error: ...`` on stderr, no
traceback, no output file); 1 only for a bug.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import sys

import puppet
from puppet import __version__
from puppet.anim import formats  # the one table of output formats (cheap: no numpy)
from puppet.anim.options import MAX_FPS, MIN_FPS, parse_background, parse_simplify, parse_tolerance, parse_workers
from puppet.batch import command as batch
from puppet.errors import SceneError
from puppet.motion import command as motion
from puppet.output import check_file, check_folder, remove_leftovers, save_png
from puppet.room import command as dressroom
from puppet.video import command as video

if "numpy" not in sys.modules and "OPENBLAS_NUM_THREADS" not in os.environ:
    # The command's BLAS work is the solvers' skinny products, which run on one thread
    # anyway (puppet/deform/threads.py): set it before numpy loads OpenBLAS, so the
    # solvers need not look the pools up and cap them at every solve (~40 ms at start).
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    os.environ["PUPPET_BLAS_SET_AT_START"] = "1"

#: Largest --size side accepted by the parser (the machine's GL may allow less: checked before drawing).
MAX_SIZE = 16384
#: Largest output in pixels (64 megapixels, e.g. 8192x8192): the compositor needs ~36 bytes per pixel.
MAX_PIXELS = 64 * 1024 * 1024


class UsageError(SceneError):
    """A bad command line flag."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, no usage dump
        raise UsageError(f"{message} (see '{self.prog} --help')")


def _size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WxH, e.g. 800x600")
    w, h = int(m.group(1)), int(m.group(2))
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise argparse.ArgumentTypeError(f"--size {text!r}: width and height must be 1..{MAX_SIZE}")
    if w * h > MAX_PIXELS:
        raise argparse.ArgumentTypeError(f"--size {text!r}: at most {MAX_PIXELS} pixels ({w * h} asked)")
    return w, h


def _time(text: str) -> float:
    try:
        t = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (t >= 0 and t < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: time must be a finite number >= 0")
    return t


def _fps(text: str) -> float:
    t = _time(text)
    if not MIN_FPS <= t <= MAX_FPS:
        raise argparse.ArgumentTypeError(f"{text!r}: fps must be in {MIN_FPS:g}..{MAX_FPS:g}")
    return t


def _background(text: str):
    try:
        return parse_background(text)
    except SceneError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _workers(text: str) -> int:
    try:
        return parse_workers(text, "")
    except SceneError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _checked(parse):
    """An argparse type from a parser of user values that raises SceneError."""
    def typed(text: str):
        try:
            return parse(text)
        except SceneError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    typed.__name__ = parse.__name__.removeprefix("parse_")  # argparse names it in "invalid ... value"
    return typed


def _threshold(text: str) -> float:
    try:
        t = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 <= t <= 256:
        raise argparse.ArgumentTypeError(f"{text!r}: the threshold must be in 0..256")
    return t


def _rect(text: str) -> tuple[float, float, float, float]:
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 4 or not all(abs(x) <= 1e6 for x in v) or v[2] < 2 or v[3] < 2:
        raise argparse.ArgumentTypeError(f"{text!r}: expected X,Y,W,H with W and H >= 2, e.g. 10,20,300,400")
    return v[0], v[1], v[2], v[3]


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="puppet", description="Pose and animate 2D characters made of layers.")
    p.add_argument("--version", action="version", version=f"puppet {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    def pose_args(q):
        g = q.add_mutually_exclusive_group()
        g.add_argument("--pose", metavar="NAME", help="a pose of the scene (default: rest)")
        g.add_argument("--time", metavar="T", type=_time, help="a time on the scene's animation, in seconds")

    r = sub.add_parser("render", help="render one frame to a PNG, offscreen")
    r.add_argument("scene")
    pose_args(r)
    r.add_argument("-o", "--output", required=True, metavar="OUT.png")
    r.add_argument("--size", type=_size, metavar="WxH", help="output size (default: the canvas)")
    r.add_argument("--wireframe", action="store_true", help="draw the mesh edges over the image")

    a = sub.add_parser("animate", help="render every frame of the scene's animation")
    a.add_argument("scene")
    a.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="the ending picks the format: " + formats.describe().replace("%", "%%"))
    a.add_argument("--format", choices=tuple(formats.BY_KIND), metavar="KIND",
                   help="name the format: " + ", ".join(formats.BY_KIND)
                        + " (spine: OUT.json; default: from the ending of -o)")
    a.add_argument("--fps", type=_fps, help="frames per second (default: the scene's)")
    a.add_argument("--from", dest="start", type=_time, metavar="T0", help="first time, seconds")
    a.add_argument("--to", dest="end", type=_time, metavar="T1", help="last time, seconds")
    a.add_argument("--size", type=_size, metavar="WxH")
    a.add_argument("--wireframe", action="store_true")
    a.add_argument("--background", type=_background, metavar="COLOR|transparent",
                   help="#rrggbb, #rrggbbaa, a colour name or transparent (not for MP4); default: the scene's")
    a.add_argument("--workers", type=_workers, metavar="N",
                   help="solver processes (default: one per core, fewer for short exports)")
    a.add_argument("--tolerance", type=_checked(parse_tolerance), metavar="PX",
                   help="web player and Spine: keys plus in-betweens where they replay puppet's frames within "
                        "PX pixels (default 1; 0: a key on every frame)")
    a.add_argument("--simplify", type=_checked(parse_simplify), metavar="PX",
                   help="Spine: lighter meshes, coarser where they draw within PX pixels of puppet's "
                        "(default: each layer's own mesh)")

    m = sub.add_parser("mesh", help="write the deformed meshes as JSON")
    m.add_argument("scene")
    pose_args(m)
    m.add_argument("-o", "--output", required=True, metavar="OUT.json")

    c = sub.add_parser("check", help="validate a scene, build its meshes and print a summary")
    c.add_argument("scene")

    i = sub.add_parser("init", help="write a scene from a picture (one layer and its mask) or from layered art (.psd .psb .ora .kra)")
    i.add_argument("image")
    i.add_argument("-o", "--output", required=True, metavar="SCENE.json")
    g = i.add_mutually_exclusive_group()
    g.add_argument("--threshold", type=_threshold, metavar="T", help="mask: luminance < T (0..256)")
    g.add_argument("--alpha", action="store_true", help="mask: alpha > 0")
    g.add_argument("--grabcut", type=_rect, metavar="X,Y,W,H", help="mask: GrabCut foreground inside the rectangle")
    i.add_argument("--pins", choices=("auto", "none"), default="none",
                   help="auto: pins at the skeleton's end points and junctions")
    i.add_argument("--links", choices=("auto", "none"), default="none",
                   help="layered art (.psd .psb .ora .kra): auto: a link where two layers overlap")
    i.add_argument("--update", action="store_true",
                   help="layered art: re-import into the existing scene, keeping its pins, links and poses "
                        "(the old scene is kept as SCENE.json.bak)")
    i.add_argument("--force", action="store_true",
                   help="layered art: replace files in SCENE-layers/ that an earlier import did not write")

    w = sub.add_parser("app", help="open the scene in a window to pin, pose and arrange it")
    w.add_argument("scene", nargs="?", help="a scene, or a picture (PNG, JPEG...): a new puppet made from it")
    w.add_argument("--size", type=_size, default=(1280, 800), metavar="WxH",
                   help="window size (default 1280x800, at least 960x640)")

    # commands that live in their own package: each module adds its parser and runs it (cheap to import)
    for module in _PLUGGED.values():
        module.add_parser(sub, size=_size, time=_time)
    return p


_PLUGGED = {"video": video, "batch": batch, "retarget": motion, "dressroom": dressroom}


def _output_file(path: str, exts: tuple[str, ...]) -> str:
    ext = os.path.splitext(path)[1].lower()
    if ext not in exts:
        raise UsageError(f"-o {path!r}: the output must end in {' or '.join(exts)}")
    return path


def _check_size(scene, size: tuple[int, int] | None, *, reserve: bool = False) -> None:
    """Refuse an output the machine's OpenGL cannot draw, before anything is drawn;
    ``reserve``: by allocating the targets the scene's own frame (its background) is then
    drawn into, not a throwaway framebuffer."""
    from puppet.render.context import output_size_problem  # lazy: moderngl, for render and animate only

    w, h = size or scene.canvas
    flag = f"--size {w}x{h}" if size else f"the canvas ({w}x{h}; give a smaller --size)"
    if w * h > MAX_PIXELS:
        raise UsageError(f"{flag}: at most {MAX_PIXELS} pixels")
    comp = scene.compositor
    keep = (lambda: comp.reserve((w, h), background=scene.background())) if reserve else None
    problem = output_size_problem(comp.ctx, (w, h), allocate=keep)
    if problem:
        raise UsageError(f"{flag}: {problem}")


@contextlib.contextmanager
def _gl_allocation(scene, size: tuple[int, int] | None):
    """A GL failure to allocate the frame while drawing becomes a user error (the size is too big)."""
    try:
        yield
    except Exception as e:
        text = str(e)
        if "OUT_OF_MEMORY" not in text and "framebuffer is not complete" not in text:
            raise
        w, h = size or scene.canvas
        raise UsageError(f"OpenGL could not allocate a {w}x{h} frame ({e}); give a smaller --size") from None


def _print(text: str) -> None:
    """Print to stdout; a stdout that cannot be written (full disk, closed pipe) is a user error."""
    try:
        print(text, flush=True)
    except BrokenPipeError:  # `puppet check s.json | head -1`: the reader has had enough
        _stdout_to_devnull()
    except OSError as e:
        _stdout_to_devnull()
        raise SceneError(f"cannot write: {e.strerror or e}", file="stdout") from None


def _stdout_to_devnull() -> None:
    """So that Python's own flush at exit does not fail (and print a traceback) again."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError):
        pass


def _is_art(path: str) -> bool:
    from puppet.imaging.layered import is_layered  # lazy: numpy, for init only

    return is_layered(path)


def _layered(args) -> bool:
    """Whether ``puppet init`` was given layered art (else --links and --update are refused)."""
    if _is_art(args.image):
        if args.threshold is not None or args.alpha or args.grabcut:
            raise UsageError(f"{args.image}: --threshold, --alpha and --grabcut are for flat pictures; "
                             "layered art keeps each layer's own alpha")
        return True
    if args.update or args.links != "none" or args.force:
        raise UsageError(f"{args.image}: --update, --links and --force are for layered art (.psd .psb .ora .kra)")
    return False


def _notes(art: str, res) -> None:
    for line in res.note_lines(art):
        print(line, file=sys.stderr)


def _init_layered(args, out: str) -> int:
    from puppet.scene.make.art import import_art  # lazy: the init command's own modules

    res = import_art(args.image, out, pins=args.pins, links=args.links, update=args.update,
                     force=args.force)
    _notes(args.image, res)
    _print(res.summary())
    return 0


def run(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "app":
        from puppet.app import main as app_main  # lazy: pyglet and imgui, never loaded by render or mesh

        return app_main.run(args.scene, size=args.size)  # art: puppet.app.model.opening.from_art
    if args.command in _PLUGGED:
        return _PLUGGED[args.command].run(args)
    if args.command == "init":
        from puppet.scene.make.picture import init_scene  # lazy: the init command's own modules

        out = _output_file(args.output, (".json",))
        if _layered(args):
            return _init_layered(args, out)
        rule = "threshold" if args.threshold is not None else "alpha" if args.alpha else \
            "grabcut" if args.grabcut else "default"
        res = init_scene(args.image, out, rule=rule, threshold=args.threshold, rect=args.grabcut, pins=args.pins)
        _print(res.summary())
        return 0
    # what can be checked without the scene is checked first (fast); again with its inputs after loading
    if args.command in ("render", "mesh"):
        out = _output_file(args.output, (".png",) if args.command == "render" else (".json",))
        check_file(out, probe=True)
    elif args.command == "animate":
        fmt = formats.find(args.output, args.format)
        formats.check_options(fmt, size=args.size, wireframe=args.wireframe, background=args.background,
                              tolerance=args.tolerance, simplify=args.simplify)
        if fmt.folder:
            check_folder(args.output, probe=True, contents=False)
        else:
            check_file(args.output, probe=True)

    from puppet.scene.format.inputs import input_files  # lazy: numpy, after the fast checks above

    scene = puppet.load_scene(args.scene)
    if args.command == "render":
        inputs = input_files(scene.data)
        check_file(out, inputs=inputs)
        _check_size(scene, args.size, reserve=True)
        with _gl_allocation(scene, args.size):
            rgba = scene.render(pose=args.pose, time=args.time, size=args.size, wireframe=args.wireframe)
        save_png(out, rgba, inputs=inputs)
    elif args.command == "mesh":
        check_file(out, inputs=input_files(scene.data))
        scene.write_mesh(out, pose=args.pose, time=args.time)
    elif args.command == "check":
        _print(scene.summary())
    elif args.command == "animate":
        from puppet.anim.export import animate_to  # lazy: the animate command's own modules

        if fmt.pixels:  # mesh formats draw nothing
            _check_size(scene, args.size)
        with _gl_allocation(scene, args.size):
            animate_to(scene, args.output, fps=args.fps, start=args.start, end=args.end, size=args.size,
                       wireframe=args.wireframe, progress=sys.stderr.isatty(), background=args.background,
                       format=args.format, workers=args.workers, say=_say, tolerance=args.tolerance,
                       simplify=args.simplify)
    return 0


class Stopped(BaseException):
    """Raised in the main thread when SIGTERM or SIGHUP arrives, so that cleanup runs."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _on_signal(signum, frame):
    for s in _handled():  # a second signal must not cut the cleanup short
        signal.signal(s, signal.SIG_IGN)
    raise Stopped(signum)


def _handled() -> list[int]:
    return [getattr(signal, n) for n in ("SIGTERM", "SIGHUP", "SIGINT") if hasattr(signal, n)]


def _install_handlers() -> None:
    for s in _handled():
        if s == signal.SIGINT:
            continue  # Python's KeyboardInterrupt
        if signal.getsignal(s) is not signal.SIG_IGN:  # keep nohup's choice
            signal.signal(s, _on_signal)


def _say(line: str) -> None:
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):  # no terminal any more (SIGHUP)
        pass


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (SIGTERM/SIGHUP end the process by that signal,
    after removing temporary files)."""
    if argv is None:
        _install_handlers()
    try:
        return run(argv)
    except SceneError as e:
        _say(f"puppet: error: {e}")
        return 2
    except KeyboardInterrupt:
        remove_leftovers()
        _say("puppet: interrupted")
        return 130
    except Stopped as e:
        remove_leftovers()
        _say(f"puppet: stopped by {signal.Signals(e.signum).name}")
        signal.signal(e.signum, signal.SIG_DFL)
        os.kill(os.getpid(), e.signum)
        return 128 + e.signum
    finally:
        remove_leftovers()


if __name__ == "__main__":
    sys.exit(main())
