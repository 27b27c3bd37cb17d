"""Small synthetic clips for the pipeline and command tests: a textured character (body and
an arm ending in a red hand) on a striped background, translated frame by frame."""
from __future__ import annotations

import json
import os

import numpy as np
from PIL import Image

W, H = 160, 120
#: Canvas coordinates of the pins on frame 0 (pixel centres are at +0.5).
PINS = {"hip": (80.5, 80.5), "shoulder": (80.5, 45.5), "hand": (124.5, 45.5)}
BONES = [["hip", "shoulder"], ["shoulder", "hand"]]


def character_mask(dx: int = 0, dy: int = 0) -> np.ndarray:
    m = np.zeros((H, W), bool)
    m[30 + dy:95 + dy, 70 + dx:90 + dx] = True   # body
    m[40 + dy:51 + dy, 90 + dx:130 + dx] = True  # arm and hand
    return m


def frame(dx: int = 0, dy: int = 0) -> np.ndarray:
    """(H, W, 3) uint8: light stripes, a dark textured character, a red hand."""
    rgb = np.full((H, W, 3), 235, np.uint8)
    rgb[::8] = 215
    m = character_mask(dx, dy)
    rng = np.random.default_rng(7)
    tex = rng.integers(0, 90, size=(H, W, 3), dtype=np.uint8)  # texture moves with the character
    tex = np.roll(tex, (dy, dx), axis=(0, 1))
    rgb[m] = tex[m]
    rgb[40 + dy:51 + dy, 120 + dx:130 + dx] = (220, 30, 30)
    return rgb


def write_folder_clip(folder, n: int = 6, step: int = 1) -> str:
    os.makedirs(folder, exist_ok=True)
    for i in range(n):
        Image.fromarray(frame(step * i)).save(os.path.join(folder, f"f{i}.png"))
    return str(folder)


def write_mp4_clip(path, n: int = 6, step: int = 1) -> str:
    import av

    with av.open(str(path), "w") as box:
        st = box.add_stream("libx264", rate=12)
        st.width, st.height, st.pix_fmt = W, H, "yuv420p"
        st.options = {"crf": "12"}
        for i in range(n):
            for p in st.encode(av.VideoFrame.from_ndarray(frame(step * i), format="rgb24")):
                box.mux(p)
        for p in st.encode():
            box.mux(p)
    return str(path)


def video_scene(source: str, **extra) -> dict:
    scene = {"puppet": 1, "source": source, "layers": [{"name": "body", "mask": {"threshold": 150}}],
             "pins": [{"name": n, "layer": "body", "at": list(at)} for n, at in PINS.items()],
             "bones": BONES, "deformer": {"method": "mls-skeleton"},
             "poses": {"wave": {"hand": [111.5, 14.5]}}}
    scene.update(extra)
    return scene


def write_scene(folder, scene: dict, name: str = "scene.json") -> str:
    path = os.path.join(str(folder), name)
    with open(path, "w") as f:
        json.dump(scene, f)
    return path
