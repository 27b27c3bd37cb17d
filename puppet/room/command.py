"""``puppet dressroom MANNEQUIN GARMENT.json [GARMENT.json ...] -o ROOM.html | ROOM/``: its
arguments and how it runs (imported by :mod:`puppet.cli`: argparse only, the room's
modules are imported when the command runs)."""
from __future__ import annotations

import argparse
import os

from puppet.errors import SceneError
from puppet.output import check_file, check_folder, write_folder, write_text


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    d = sub.add_parser("dressroom", help="write a virtual dressing room: garments to put on a mannequin, as a web page",
                       description="MANNEQUIN is a picture or a scene (drawn at rest); each GARMENT.json is a scene "
                                   "on the mannequin's canvas, drawn at its pose 'fit' (else at rest). ROOM.html is "
                                   "one self-contained file; ROOM/ a folder of index.html and the pictures, loaded "
                                   "as the page needs them (for catalogues). See docs/dressroom.md.")
    d.add_argument("mannequin", metavar="MANNEQUIN")
    d.add_argument("garments", nargs="+", metavar="GARMENT.json")
    d.add_argument("-o", "--output", required=True, metavar="ROOM.html|ROOM/")
    return d


def is_folder(path: str) -> bool:
    """The folder form: a path ending in a slash, or an existing folder without an .html ending."""
    html = os.path.splitext(path.rstrip("/" + os.sep))[1].lower() in (".html", ".htm")
    return path.endswith(("/", os.sep)) or (os.path.isdir(path) and not html)


def run(args: argparse.Namespace) -> int:
    """Check the output, read and render everything, then write the page at once; 0 on success."""
    from puppet.room.model import load_room  # lazy: numpy and the scene stack, for this command only
    from puppet.room.page import MAX_BYTES, room_html, write_room_folder  # lazy: as above

    out, folder = args.output, is_folder(args.output)
    if not folder and os.path.splitext(out)[1].lower() not in (".html", ".htm"):
        raise SceneError(f"-o {out!r}: give ROOM.html (one file) or ROOM/ (a folder)")
    inputs = [(args.mannequin, "the mannequin")] + [(p, "a garment") for p in args.garments]
    if folder:
        check_folder(out, probe=True, inputs=inputs)
    else:
        check_file(out, probe=True, inputs=inputs)
    room = load_room(args.mannequin, args.garments)
    if folder:
        write_folder(out, lambda tmp: write_room_folder(room, tmp, out), inputs=inputs)
        return 0
    text = room_html(room, out)
    size = len(text.encode("utf-8"))
    if size > MAX_BYTES:
        raise SceneError(f"-o {out!r}: the room would be {size / 2**20:.1f} MB, over the single-file limit of "
                         f"{MAX_BYTES >> 20} MB (write the folder form: -o ROOM/)")
    write_text(out, text, inputs=inputs)
    return 0
