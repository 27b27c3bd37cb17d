"""The ``puppet`` command: render, animate, mesh, check.

Exit status: 0 success; 2 bad input (one line ``puppet: error: ...`` on stderr, no
traceback, no output file); 1 only for a bug.
"""
from __future__ import annotations

import argparse
import os
import re
import sys

from puppet.errors import SceneError

MAX_SIZE = 16384


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
    if not 0 < t <= 240:
        raise argparse.ArgumentTypeError(f"{text!r}: fps must be in (0, 240]")
    return t


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="puppet", description="Pose and animate 2D characters made of layers.")
    p.add_argument("--version", action="version", version=f"puppet {_version()}")
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
    a.add_argument("-o", "--output", required=True, metavar="OUT.gif|OUT.mp4|OUT_DIR/")
    a.add_argument("--fps", type=_fps, help="frames per second (default: the scene's)")
    a.add_argument("--from", dest="start", type=_time, metavar="T0", help="first time, seconds")
    a.add_argument("--to", dest="end", type=_time, metavar="T1", help="last time, seconds")
    a.add_argument("--size", type=_size, metavar="WxH")
    a.add_argument("--wireframe", action="store_true")

    m = sub.add_parser("mesh", help="write the deformed meshes as JSON")
    m.add_argument("scene")
    pose_args(m)
    m.add_argument("-o", "--output", required=True, metavar="OUT.json")

    c = sub.add_parser("check", help="validate a scene, build its meshes and print a summary")
    c.add_argument("scene")
    return p


def _version() -> str:
    from puppet import __version__

    return __version__


def _output_file(path: str, exts: tuple[str, ...]) -> str:
    ext = os.path.splitext(path)[1].lower()
    if ext not in exts:
        raise UsageError(f"-o {path!r}: the output must end in {' or '.join(exts)}")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise UsageError(f"-o {path!r}: folder {folder!r} does not exist")
    if os.path.isdir(path):
        raise UsageError(f"-o {path!r}: is a folder")
    return path


def run(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    import puppet

    if args.command == "render":
        out = _output_file(args.output, (".png",))
        scene = puppet.load_scene(args.scene)
        rgba = scene.render(pose=args.pose, time=args.time, size=args.size, wireframe=args.wireframe)
        from puppet.imaging.io import save_png

        save_png(out, rgba)
    elif args.command == "mesh":
        out = _output_file(args.output, (".json",))
        scene = puppet.load_scene(args.scene)
        scene.write_mesh(out, pose=args.pose, time=args.time)
    elif args.command == "check":
        scene = puppet.load_scene(args.scene)
        print(scene.summary())
    elif args.command == "animate":
        from puppet.anim.export import animate_to

        scene = puppet.load_scene(args.scene)
        animate_to(scene, args.output, fps=args.fps, start=args.start, end=args.end, size=args.size,
                   wireframe=args.wireframe, progress=sys.stderr.isatty())
    return 0


def main(argv: list[str] | None = None) -> int:
    try:
        return run(argv)
    except SceneError as e:
        print(f"puppet: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("puppet: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
