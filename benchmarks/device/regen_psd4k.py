"""Re-make the 4K PSD scene's layer PNGs (bench_import.make_psd's pixels, cropped as init cropped them):
    python3 benchmarks/device/regen_psd4k.py FOLDER   (FOLDER holds s.json and shapes.json)"""
import json
import os
import sys

from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.bench_import import psd_parts  # noqa: E402

d = os.path.abspath(sys.argv[1])
parts = {f"part{i}": (a, x, y) for i, a, x, y in psd_parts(4000, 20)}
scene = json.load(open(os.path.join(d, "s.json")))
shapes = json.load(open(os.path.join(d, "shapes.json")))
os.makedirs(os.path.join(d, "s-layers"), exist_ok=True)
for L in scene["layers"]:
    a, x, y = parts[L["name"].split("/")[-1]]
    ox, oy = L["offset"]
    hh, ww = shapes[L["name"]]
    Image.fromarray(a[oy - y:oy - y + hh, ox - x:ox - x + ww]).save(os.path.join(d, L["image"]), compress_level=1)
open(os.path.join(d, "scene.txt"), "w").write(os.path.join(d, "s.json"))
print("regen: layers", len(scene["layers"]))
