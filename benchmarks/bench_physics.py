"""Secondary motion (puppet.scene.time.physics): what a chain adds to an export.

Two bundled scenes exported to a GIF as they are and with a chain, each twice, wall time
and process time: the T-rex (``trex-layers.json``, 2 s at 12 fps) with its tail as a chain
(``hip``, a new ``tail_mid`` pin, ``tail_tip``) and the character (``character.json``, 2 s
at 24 fps) with its right arm as one (``shoulder_r``, ``hand_r``: the hand lags and
overshoots its keyed path); both 2 Hz, damping 0.3. Then the chain's stepping alone over
a 10 s animation (2400 steps at 240 a second). The issue's target: physics adds at most
20 % to an export's time.

    python benchmarks/bench_physics.py
"""
from __future__ import annotations

import os
import tempfile
import time

import numpy as np

import puppet
from puppet.cli import main

SCENES = os.path.join(os.path.dirname(__file__), "..", "assets", "scenes")


CHAINS = {  # scene -> (pins added, the chain)
    "trex-layers": ([{"name": "tail_mid", "layer": "tail", "at": [450, 330]}], ["hip", "tail_mid", "tail_tip"]),
    "character": ([], ["shoulder_r", "hand_r"]),
}


def scenes(name: str, folder: str) -> dict[str, str]:
    """The bundled scene saved into ``folder`` as it is ("no") and with its chain ("yes")."""
    out = {}
    for tag in ("no", "yes"):
        doc = puppet.load_scene(os.path.join(SCENES, name + ".json"))
        if tag == "yes":
            pins, chain = CHAINS[name]
            for p in pins:
                doc.add_pin(p["name"], p["layer"], p["at"])
            doc.set_physics([{"pins": chain, "frequency": 2.0, "damping": 0.3}])
        out[tag] = os.path.join(folder, f"{name}-{tag}.json")
        doc.save(out[tag], copy=True)
    return out


def main_() -> None:
    print(f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'scene':12} {'chain':6} {'run':>4} {'wall s':>8} {'cpu s':>8}")
    with tempfile.TemporaryDirectory() as d:
        for name in CHAINS:
            for tag, path in scenes(name, d).items():
                for run in (1, 2):
                    w, c = time.perf_counter(), time.process_time()
                    assert main(["animate", path, "-o", os.path.join(d, "a.gif")]) == 0
                    print(f"{name:12} {tag:6} {run:>4} {time.perf_counter() - w:8.2f} {time.process_time() - c:8.2f}")
        doc = puppet.load_scene(os.path.join(d, "character-yes.json"))
        sim = doc.tracks().physics
        c = time.process_time()
        sim.positions(10.0)
        print(f"stepping the chain over 10 s ({10 * 240} steps): {time.process_time() - c:.3f} s of CPU")
        hand = [doc.data.pins[i].name for i in sim.cols].index("hand_r")
        lag = max(np.hypot(*(sim.positions(t)[hand] - doc.state(time=t).to[sim.cols[hand]]))
                  for t in np.arange(0, 2, 0.05))
        print(f"largest lag of the character's right hand behind its keyed path: {lag:.1f} px")


if __name__ == "__main__":
    main_()
