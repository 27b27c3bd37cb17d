"""``puppet video``: its arguments and how it runs (imported by puppet.cli; keep it cheap to import)."""
from __future__ import annotations

import argparse

from puppet.errors import SceneError


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    v = sub.add_parser("video", help="re-pose a character through a video whose first frame holds the skeleton")
    v.add_argument("scene")
    v.add_argument("--pose", required=True, metavar="NAME", help="the target skeleton: a pose of the scene")
    v.add_argument("-o", "--output", required=True, metavar="OUT.mp4|OUT.webm|OUT_DIR/")
    v.add_argument("--tracks", metavar="TRACKS.json", help="also write the tracked joints")
    v.add_argument("--from", dest="start", type=int, metavar="N", help="first frame (default 0)")
    v.add_argument("--to", dest="end", type=int, metavar="M", help="last frame (default: the last)")
    return v


def run(args: argparse.Namespace) -> int:
    raise SceneError("puppet video: not built yet")
