"""Do the bundled scenes give the same meshes as at another commit? (bit for bit)

Run:  python benchmarks/compare_meshes.py [BASE]      (BASE: a git commit, default 2a77ab8)
Extracts BASE's `puppet/` into a temporary folder (git archive), then in two processes
(BASE's code and this tree's) solves every scene of assets/scenes at rest, in every pose
and at two animation times, hashing the deformed vertices and depths of every layer;
prints one line per state and the count of differences. Renders depend only on these
meshes, the images and the unchanged compositor, so equal meshes mean equal pictures.
"""
from __future__ import annotations

import glob
import hashlib
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def hashes() -> dict:
    import numpy as np

    import puppet

    out = {}
    for f in sorted(glob.glob(os.path.join(ROOT, "assets", "scenes", "*.json"))):
        name = os.path.basename(f)
        try:
            sc = puppet.load_scene(f)
        except Exception as e:  # noqa: BLE001 (a scene one side refuses is a difference too)
            out[name] = f"error: {e}"
            continue
        states = [("pose", p) for p in [None] + sorted(sc.data.poses)]
        if sc.data.animation is not None:
            states += [("time", 0.37), ("time", 0.8)]
        for kind, v in states:
            res = sc.layers(v) if kind == "pose" else sc.layers(time=v)
            h = hashlib.sha1()
            for r in res:
                h.update(np.ascontiguousarray(r.deformed).tobytes())
                h.update(np.ascontiguousarray(r.depth).tobytes())
            out[f"{name} {kind} {v}"] = h.hexdigest()
    return out


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--hashes":
        json.dump(hashes(), sys.stdout)
        return
    base = sys.argv[1] if len(sys.argv) > 1 else "2a77ab8"
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(f"git -C {ROOT} archive {base} puppet shaders | tar -x -C {tmp}", shell=True, check=True)
        runs = {}
        for label, path in (("base", tmp), ("this", ROOT)):
            env = dict(os.environ, PYTHONPATH=path)
            p = subprocess.run([sys.executable, os.path.abspath(__file__), "--hashes"], env=env, cwd=tmp,
                               capture_output=True, text=True, check=True)
            runs[label] = json.loads(p.stdout)
    a, b = runs["base"], runs["this"]
    diff = 0
    for k in sorted(set(a) | set(b)):
        same = a.get(k) == b.get(k)
        diff += not same
        print(f"{'same' if same else 'DIFFERENT'}  {k}")
    print(f"{len(a)} states at {base}, {len(b)} here, {diff} different")


if __name__ == "__main__":
    main()
