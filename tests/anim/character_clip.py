"""The keyed exports' test animation: the seven-part character of :mod:`tests.artfiles`
rigged by ``puppet init --pins auto --links auto`` and posed over 4 s at 12 fps (49
frames, smooth eases): an arm waves, the legs step, the head nods. The poses move each
layer's pins by set amounts from where the automatic rig put them (whatever their names),
so the clip does not depend on the rig's naming."""
from __future__ import annotations

import json
import os

import numpy as np

from puppet.cli import main
from tests.artfiles import write_psd

#: Per pose: layer -> how far (x, y px) its pin farthest from the canvas centre moves.
POSES = {
    "wave": {"arm_front": (20, -125), "arm_back": (-15, 55)},
    "step": {"legs/left": (-45, -30), "legs/right": (50, -15), "arm_front": (-25, 35)},
    "nod": {"head": (20, 20), "arm_back": (25, -95)},
}


def character_clip(folder: str) -> str:
    """Write ``char.psd`` and ``char.json`` (the animation added) in ``folder``; the scene's path."""
    psd, scene = os.path.join(folder, "char.psd"), os.path.join(folder, "char.json")
    write_psd(psd)
    assert main(["init", psd, "-o", scene, "--pins", "auto", "--links", "auto"]) == 0
    with open(scene) as f:
        data = json.load(f)
    centre = np.array(data["canvas"], float) / 2
    poses = {}
    for name, moves in POSES.items():
        pose = {}
        for layer, (dx, dy) in moves.items():
            pins = [p for p in data["pins"] if p["layer"] == layer]
            far = max(pins, key=lambda p: float(np.hypot(*(np.asarray(p["at"]) - centre))))
            pose[far["name"]] = [far["at"][0] + dx, far["at"][1] + dy]
        poses[name] = pose
    data["poses"] = poses
    data["animation"] = {"fps": 12, "keys": [{"time": 0, "pose": "rest"}] + [
        {"time": i + 1, "pose": name, "ease": "smooth"} for i, name in enumerate(POSES)] + [
        {"time": 4, "pose": "rest", "ease": "smooth"}]}
    with open(scene, "w") as f:
        json.dump(data, f, indent=1)
    return scene
