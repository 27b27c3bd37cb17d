"""``puppet retarget``: its arguments and how it runs (imported by puppet.cli; keep it cheap to import)."""
from __future__ import annotations

import argparse
import json
import os

import puppet
from puppet.errors import SceneError
from puppet.output import Staged, check_file, commit_all


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    r = sub.add_parser("retarget", help="write a copy of a scene whose animation plays a BVH motion capture clip")
    r.add_argument("scene")
    r.add_argument("motion", metavar="MOTION.bvh")
    r.add_argument("-o", "--output", required=True, metavar="OUT.json",
                   help="the scene with the motion as its animation; the map used goes to OUT.map.json")
    r.add_argument("--map", default="auto", metavar="auto|MAP.json",
                   help='which joint each pin follows: found from names and places (auto, the default), '
                        'or a file {"PIN": "JOINT"} (as OUT.map.json is written)')
    r.add_argument("--projection", default="auto", choices=("auto", "frontal", "sagittal", "pca"),
                   help="the plane the motion is seen in (auto: frontal, or sagittal for a character in profile)")
    r.add_argument("--scale", default="body", choices=("body", "limbs"),
                   help="one scale for the whole motion (body, the default: by leg length, else height), "
                        "or each limb's own (limbs: its length on the character over the motion's)")
    r.add_argument("--in-place", action="store_true", help="take out the root's move along the ground")
    r.add_argument("--start", type=time, metavar="S", help="first second of the motion used (default 0)")
    r.add_argument("--end", type=time, metavar="S", help="last second of the motion used (default: its end)")
    return r


def map_path(output: str) -> str:
    """``OUT.map.json`` beside ``OUT.json``."""
    return os.path.splitext(output)[0] + ".map.json"


def run(args: argparse.Namespace) -> int:
    """Read, retarget and write the scene and its map (both or neither); 0 on success."""
    from puppet.motion.bvh import read_bvh  # lazy: numpy and scipy, not loaded by the CLI's parser
    from puppet.motion.mapping import read_map  # lazy: as above
    from puppet.motion.retarget import animation, retarget  # lazy: as above
    from puppet.scene.document.core import Document  # lazy: as above
    from puppet.scene.format.inputs import input_files  # lazy: as above
    from puppet.scene.format.write import map_paths, relative_to, scene_text  # lazy: as above

    if not args.output.lower().endswith(".json"):
        raise SceneError(f"-o {args.output!r}: the output must end in .json")
    maps = map_path(args.output)
    for path in (args.output, maps):
        check_file(path, probe=True)
    if args.start is not None and args.end is not None and args.end < args.start:
        raise SceneError(f"--end {args.end:g} is before --start {args.start:g}")
    scene = puppet.load_scene(args.scene)
    motion = read_bvh(args.motion)
    pins = {p.name: p.at for p in scene.data.pins if p.kind != "starch"}
    if not pins:
        raise SceneError("the scene has no pins to move", file=scene.file)
    given = None if args.map == "auto" else read_map(args.map, list(pins), motion.names)
    r = retarget(motion, pins, mapping=given, projection=args.projection, in_place=args.in_place,
                 start=args.start, end=args.end, scale=args.scale,
                 labels={p.name: p.layer for p in scene.data.pins if p.kind != "starch"})
    doc = scene.to_dict()
    doc["animation"] = animation(r)
    out = Document(doc, os.path.abspath(args.output))  # validated as a loaded file would be
    # a map read back from OUT.map.json is left as it is (the map used is the map given)
    same = given is not None and os.path.realpath(args.map) == os.path.realpath(maps)
    inputs = input_files(scene.data) + [(args.motion, "MOTION")] + ([(args.map, "--map")] if given and not same else [])
    text = scene_text(map_paths(out.to_dict(), relative_to(os.path.dirname(os.path.abspath(args.output)))))
    writes = [(args.output, text)] + ([] if same else [(maps, json.dumps(r.map, indent=2) + "\n")])
    staged = []
    try:
        for path, body in writes:
            staged.append(Staged(path, lambda tmp, body=body: _write(tmp, body), inputs=inputs))
    except BaseException:
        for s in staged:
            s.discard()
        raise
    commit_all(staged)
    keys = len(doc["animation"]["keys"])
    print(f"puppet: {len(r.times)} frames ({r.times[-1]:.2f} s, {r.projection}) onto {len(r.map)} pins: "
          f"{keys} keys in {args.output}, the map in {maps}")
    return 0


def _write(tmp: str, text: str) -> None:
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
