"""Re-make the 4K PSD scene's layer PNGs (bench_import.make_psd's pixels, cropped as init cropped them):
    python3 benchmarks/device/regen_psd4k.py FOLDER   (FOLDER holds s.json and shapes.json)"""
import json, os, sys, numpy as np
from PIL import Image
d = os.path.abspath(sys.argv[1])
rng = np.random.default_rng(1)
size, parts = 4000, {}
for i in range(20):
    w, h = int(size * rng.uniform(0.2, 0.3)), int(size * rng.uniform(0.3, 0.4))
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    r = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
    a = np.zeros((h, w, 4), np.uint8)
    base = rng.integers(40, 215, 3)
    for c in range(3):
        a[..., c] = np.clip(base[c] + 40 * (yy / h - 0.5) + 8 * np.sin(xx / 9.0 + c), 0, 255)
    a[..., 3] = np.clip((1 - r) * 60, 0, 1) * 255
    x, y = int(rng.uniform(0, size - w)), int(rng.uniform(0, size - h))
    parts[f"part{i}"] = (a, x, y)
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
