"""An export run as a child process, for the app's File > Export
(:mod:`puppet.app.model.exporter`): ``python -m puppet.anim.export_child SCENE OUTPUT
OPTIONS_JSON`` writes the scene's animation with :func:`puppet.anim.export.animate_to` and
prints ``progress I N`` lines; SIGINT stops it (exit 130) and the export's atomic write
leaves nothing behind; a scene error is one ``puppet: error:`` line on stderr, exit 2.
"""
from __future__ import annotations

import json
import signal
import sys

from puppet.anim.export import animate_to, frame_count
from puppet.api import load_scene
from puppet.errors import SceneError


def main(argv: list[str]) -> int:
    """The child: ``SCENE OUTPUT OPTIONS_JSON``; prints ``progress I N``; exit 2 on a scene error."""
    scene_path, output, options = argv[0], argv[1], json.loads(argv[2])
    try:
        scene = load_scene(scene_path)
        anim = scene.data.animation
        if anim is None:
            raise SceneError("the scene has no animation to export: add keys first")
        fps = float(options.get("fps") or anim.fps)
        t0 = float(options["start"]) if options.get("start") is not None else anim.keys[0].time
        t1 = float(options["end"]) if options.get("end") is not None else anim.keys[-1].time
        total = frame_count(t0, t1, fps)
        kw = {k: options[k] for k in ("fps", "start", "end", "background") if options.get(k) is not None}
        if options.get("size"):
            kw["size"] = tuple(options["size"])
        animate_to(scene, output, progress=lambda done, n: print(f"progress {done} {n}", flush=True), **kw)
        print(f"progress {total} {total}", flush=True)
    except SceneError as e:
        print(f"puppet: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.exit(main(sys.argv[1:]))
