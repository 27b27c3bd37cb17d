"""Cut the bundled clips out of the BVH files of facebookresearch/AnimatedDrawings (MIT).

    python assets/motion/make_clips.py PATH/TO/AnimatedDrawings/examples/bvh

Each clip keeps its file's HIERARCHY as it is; MOTION keeps every ``step``-th row from
``first`` for ``count`` rows, and the frame time is multiplied by ``step``.
"""
from __future__ import annotations

import os
import sys

#: name: (source under examples/bvh, first row, step, rows)
CLIPS = {
    "walk.bvh": ("fair1/zombie.bvh", 0, 1, 120),
    "wave.bvh": ("fair1/wave_hello.bvh", 0, 4, 120),
    "jumping_jacks.bvh": ("cmu1/jumping_jacks.bvh", 0, 1, 125),
    "dance.bvh": ("rokoko/jesse_dance.bvh", 0, 4, 100),
}


def cut(text: str, first: int, step: int, count: int) -> str:
    lines = text.splitlines()
    m = next(i for i, line in enumerate(lines) if line.strip() == "MOTION")
    frame_time = float(lines[m + 2].split(":")[1])
    rows = [line.strip() for line in lines[m + 3:] if line.strip()][first::step][:count]
    head = [line.rstrip() for line in lines[:m + 1]]
    return "\n".join(head + [f"Frames: {len(rows)}", f"Frame Time: {frame_time * step:.6f}"] + rows) + "\n"


def main(src: str) -> None:
    here = os.path.dirname(os.path.abspath(__file__))
    for name, (path, first, step, count) in CLIPS.items():
        with open(os.path.join(src, path), encoding="utf-8") as f:
            text = cut(f.read(), first, step, count)
        with open(os.path.join(here, name), "w", encoding="utf-8") as f:
            f.write(text)


if __name__ == "__main__":
    main(sys.argv[1])
