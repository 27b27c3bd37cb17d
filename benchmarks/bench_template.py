"""Template mode: match scores and time per picture.

Carries the bundled t-shirt and dress templates to generated and bundled pictures and
prints, for each, the match score (symmetric mean outline distance under the landmark
correspondence / sqrt(area); refused above 0.08 by default), the nearest-point distance,
the matched landmarks, the largest pin error where the true position is known, and the
median wall and CPU (``process_time``) time of ``Template.transfer`` (the template
itself is read once). The t-shirt template with an automatic 12-vertex cage
(``caged.json``) is carried to the t-shirt pictures whose truth is known too: its rows
add the largest cage vertex error and the handles pushed out to hold the picture's mesh.

    .venv/bin/python benchmarks/bench_template.py [--repeat N]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from puppet.batch.template import TOLERANCE, Template  # noqa: E402
from tests.batch import garments as G  # noqa: E402

DRESS_TEMPLATE = os.path.join(ROOT, "assets", "scenes", "dress-garment.json")


def pictures(d: str) -> list[tuple[str, str, object]]:
    """(template, picture, true pin map or None)."""
    out = []
    a, b = G.similar_copy(G.TSHIRT, os.path.join(d, "tshirt_sim.png"), scale=0.6, angle=25, shift=(60, 10),
                          size=(420, 400))
    out.append((G.TSHIRT_TEMPLATE, os.path.join(d, "tshirt_sim.png"), (a, b)))
    a2, b2 = G.similar_copy(G.TSHIRT, os.path.join(d, "tshirt_big.png"), scale=1.5, angle=-8, shift=(40, 80),
                            size=(860, 900))
    out.append((G.TSHIRT_TEMPLATE, os.path.join(d, "tshirt_big.png"), (a2, b2)))
    out.append((G.TSHIRT_TEMPLATE, G.reproportioned(os.path.join(d, "tshirt_warped.png")), "warp"))
    out.append((G.TSHIRT_TEMPLATE, G.kenney_tshirt(os.path.join(d, "kenney_tshirt.png"))[0], None))
    for p in (G.DRESS, G.circle(os.path.join(d, "circle.png")), os.path.join(G.KENNEY, "blueShirt1.png"),
              os.path.join(G.KENNEY, "pantsLightBlue_long.png"), os.path.join(ROOT, "assets", "trex", "Body.PNG")):
        out.append((G.TSHIRT_TEMPLATE, p, None))
    a3, b3 = G.similar_copy(G.DRESS, os.path.join(d, "dress_sim.png"), scale=0.7, angle=-15, shift=(40, 80),
                            size=(460, 460))
    out.append((DRESS_TEMPLATE, os.path.join(d, "dress_sim.png"), (a3, b3)))
    out.append((DRESS_TEMPLATE, G.TSHIRT, None))
    caged = G.caged_template(d, {"auto": 12, "offset": 10})
    out += [(caged, pic, truth) for t, pic, truth in out[:3]]
    return out


def error(X, got, truth) -> float | None:
    """Largest distance of ``got`` from where ``truth`` sends the template's ``X``."""
    if truth is None:
        return None
    X = np.asarray(X, float)
    if truth == "warp":
        want = G.warp_forward(X)
    else:
        a, b = truth
        z = a * (X[:, 0] + 1j * X[:, 1]) + b
        want = np.stack([z.real, z.imag], axis=1)
    return float(np.linalg.norm(np.asarray(got, float) - want, axis=1).max())


def _px(e: float | None) -> str:
    return f"{e:.2f}" if e is not None else "-"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f}")
    templates: dict[str, Template] = {}
    print(f"{'template':<22} {'picture':<28} {'score':>6} {'nearest':>7} {'lm':>3} {'pin err px':>10} "
          f"{'ms':>6} {'cpu ms':>6}  result  [cage err px, pushed]")
    with tempfile.TemporaryDirectory() as d:
        for tp, pic, truth in pictures(d):
            tpl = templates.setdefault(tp, Template(tp))
            times, cpu = [], []
            for _ in range(args.repeat):
                t0, c0 = time.perf_counter(), time.process_time()
                r = tpl.transfer(pic, tolerance=1.0)
                times.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
            e = error([p.at for p in tpl.pins], [p["at"] for p in r.scene["pins"]], truth)
            result = "match" if r.score <= TOLERANCE else f"NoMatch at {TOLERANCE}"
            if tpl.cage is not None:
                result += f"  [{_px(error(tpl.cage, r.scene['layers'][0]['cage']['points'], truth))}, {r.grown}]"
            print(f"{os.path.basename(tp):<22} {os.path.basename(pic):<28} {r.score:6.3f} {r.distance:7.3f} "
                  f"{r.landmarks:3d} {_px(e):>10} {1000 * np.median(times):6.0f} {1000 * np.median(cpu):6.0f}  {result}")


if __name__ == "__main__":
    main()
