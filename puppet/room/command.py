"""``puppet dressroom MANNEQUIN GARMENT.json [GARMENT.json ...] -o ROOM.html``: its
arguments and how it runs (imported by :mod:`puppet.cli`: argparse only, the room's
modules are imported when the command runs)."""
from __future__ import annotations

import argparse
import os

from puppet.errors import SceneError
from puppet.output import check_file, write_text


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    d = sub.add_parser("dressroom", help="write a virtual dressing room: garments to put on a mannequin, as a web page",
                       description="MANNEQUIN is a picture or a scene (drawn at rest); each GARMENT.json is a scene "
                                   "on the mannequin's canvas, drawn at its pose 'fit' (else at rest). "
                                   "See docs/dressroom.md.")
    d.add_argument("mannequin", metavar="MANNEQUIN")
    d.add_argument("garments", nargs="+", metavar="GARMENT.json")
    d.add_argument("-o", "--output", required=True, metavar="ROOM.html")
    return d


def run(args: argparse.Namespace) -> int:
    """Check the output, read and render everything, then write the page at once; 0 on success."""
    from puppet.room.model import load_room  # lazy: numpy and the scene stack, for this command only
    from puppet.room.page import MAX_BYTES, room_html  # lazy: as above

    out = args.output
    if os.path.splitext(out)[1].lower() not in (".html", ".htm"):
        raise SceneError(f"-o {out!r}: the dressing room is one HTML file: give ROOM.html")
    inputs = [(args.mannequin, "the mannequin")] + [(p, "a garment") for p in args.garments]
    check_file(out, probe=True, inputs=inputs)
    text = room_html(load_room(args.mannequin, args.garments), out)
    size = len(text.encode("utf-8"))
    if size > MAX_BYTES:
        raise SceneError(f"-o {out!r}: the room would be {size / 2**20:.1f} MB, over the single-file limit of "
                         f"{MAX_BYTES >> 20} MB (give fewer garments or a smaller canvas)")
    write_text(out, text, inputs=inputs)
    return 0
