"""Ground-truth clips for the tracker: puppet renders a bundled character along known pin paths.

Each frame is ``scene.render(pose=...)`` with some pins moved along smooth paths (the others at
rest), drawn at the clip's size, then turned / scaled / moved as a whole (``cv2.warpAffine``)
and partly covered by another picture passing in front. Every pin's true position is known:
its target, through the same transforms. Frames are generated deterministically and cached as
``.npz`` under ``$PUPPET_CACHE`` (default: ``<tempdir>/puppet-cache``)/``video-gt``.

Coordinates: a pin at canvas ``x`` is at OpenCV pixel coordinate ``x * s - 0.5`` in a render of
scale ``s`` (the renderer maps canvas 0 to the left edge of pixel 0).
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from dataclasses import dataclass

import numpy as np

import puppet

VERSION = 4
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@dataclass
class Clip:
    """A generated clip and its truth.

    Attributes
    ----------
    name : str
    frames : (n, H, W, 3) uint8 array
    joints : dict of str to (n, 2) float array
        True pin positions per frame (OpenCV pixel coordinates).
    visible : dict of str to (n,) bool array
        False where the occluder covers the joint.
    masks : (n, H, W) bool array
        The character's foreground (before the occluder).
    """

    name: str
    frames: np.ndarray
    joints: dict[str, np.ndarray]
    visible: dict[str, np.ndarray]
    masks: np.ndarray

    @property
    def size(self) -> tuple[int, int]:
        return int(self.frames.shape[2]), int(self.frames.shape[1])


def _wave(t: np.ndarray | float, periods: float, phase: float = 0.0):
    return np.sin(2 * np.pi * (periods * t + phase))


def _swing(pivot: tuple[float, float], degrees):
    """A pin path: the pin turned about ``pivot`` by ``degrees(t)`` (limbs keep their length)."""
    def path(rest: np.ndarray, t: float) -> np.ndarray:
        a = np.radians(float(degrees(t)))
        d = rest - np.asarray(pivot, float)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        return np.asarray(pivot, float) + rot @ d
    return path


# name -> scene file, pin paths (limbs turned about their joints, functions of t in [0, 1]),
# global motion of the frame, occluder
SPECS: dict[str, dict] = {
    "trex": {
        "scene": "assets/scenes/trex-layers.json",
        "fit": 0.78,
        "paths": {
            # the head nods about the neck (the jaw is linked to the top of the head at the front)
            "jaw": _swing((193, 152), lambda t: -10 * _wave(t, 1.5)),
            "snout": _swing((193, 152), lambda t: -10 * _wave(t, 1.5)),
            "tail_tip": _swing((360, 307), lambda t: 14 * _wave(t, 1.5)),
            "hand_front": _swing((198, 260), lambda t: 30 * _wave(t, 2)),
            "foot_left": _swing((256, 343), lambda t: 18 * _wave(t, 1)),
        },
        "turn": 12.0, "zoom": 0.1, "shift": (40.0, 20.0),
        "occluder": "assets/noto-emoji/emoji_u1f457.png",
    },
    "character": {
        "scene": "assets/scenes/character.json",
        "fit": 0.75,
        "paths": {
            "hand_r": _swing((427.5, 289.5), lambda t: -50 * (0.5 - 0.5 * np.cos(2 * np.pi * 1.5 * t))),
            "hand_l": _swing((262.5, 281.5), lambda t: 30 * _wave(t, 2, 0.3)),
            "foot_r": _swing((385, 430), lambda t: -25 * np.maximum(0, _wave(t, 1))),
            "head": _swing((351, 250), lambda t: 8 * _wave(t, 2.5)),
        },
        "turn": 15.0, "zoom": 0.12, "shift": (50.0, 15.0),
        "occluder": "assets/noto-emoji/emoji_u1f3c3.png",
    },
}


def clip_names() -> list[str]:
    return list(SPECS)


def _cache_dir() -> str:
    base = os.environ.get("PUPPET_CACHE") or os.path.join(tempfile.gettempdir(), "puppet-cache")
    path = os.path.join(base, "video-gt")
    os.makedirs(path, exist_ok=True)
    return path


def _key(name: str, n: int, size: tuple[int, int]) -> str:
    spec = SPECS[name]
    with open(os.path.join(ROOT, spec["scene"]), "rb") as f:
        scene_hash = hashlib.sha1(f.read()).hexdigest()[:10]
    return f"{name}-{n}-{size[0]}x{size[1]}-v{VERSION}-{scene_hash}"


def load_clip(name: str, *, n: int = 100, size: tuple[int, int] = (640, 480), cache: bool = True) -> Clip:
    """The ground-truth clip ``name`` (see :func:`clip_names`), generated once and cached.

    Parameters
    ----------
    n : int
        Number of frames.
    size : (W, H)
        Frame size.
    cache : bool
        Read and write the cache (``False``: always generate, write nothing).
    """
    path = os.path.join(_cache_dir(), _key(name, n, size) + ".npz")
    if cache and os.path.exists(path):
        with np.load(path) as z:
            names = json.loads(str(z["names"]))
            return Clip(name, z["frames"], {k: z["joints"][:, i] for i, k in enumerate(names)},
                        {k: z["visible"][:, i] for i, k in enumerate(names)}, z["masks"])
    clip = generate_clip(name, n=n, size=size)
    if cache:
        names = list(clip.joints)
        tmp = path + f".{os.getpid()}.tmp.npz"
        np.savez_compressed(tmp, frames=clip.frames, masks=clip.masks, names=json.dumps(names),
                            joints=np.stack([clip.joints[k] for k in names], 1),
                            visible=np.stack([clip.visible[k] for k in names], 1))
        os.replace(tmp, path)
    return clip


def global_motion(name: str, t: float, size: tuple[int, int]) -> np.ndarray:
    """The (2, 3) similarity applied to the whole frame at time ``t`` in [0, 1]."""
    import cv2

    spec = SPECS[name]
    W, H = size
    angle = spec["turn"] * _wave(t, 1)
    scale = 1.0 + spec["zoom"] * _wave(t, 0.7, 0.1)
    M = cv2.getRotationMatrix2D(((W - 1) / 2, (H - 1) / 2), float(angle), float(scale))
    # shifts are given for 640x480 and scale with the frame
    M[:, 2] += (spec["shift"][0] * W / 640 * _wave(t, 0.5), spec["shift"][1] * H / 480 * _wave(t, 1.3, 0.2))
    return M


def generate_clip(name: str, *, n: int = 100, size: tuple[int, int] = (640, 480)) -> Clip:
    """Render the clip ``name`` (no cache): ``n`` frames of ``size`` (W, H)."""
    import cv2
    from PIL import Image

    spec = SPECS[name]
    scene = puppet.load_scene(os.path.join(ROOT, spec["scene"]))
    raw = json.load(open(os.path.join(ROOT, spec["scene"])))
    rest = {p["name"]: np.array(p["at"], float) for p in raw["pins"]}
    cw, ch = raw["canvas"]
    W, H = size
    s = spec["fit"] * min(W / cw, H / ch)
    rw, rh = int(round(cw * s)), int(round(ch * s))
    s_x, s_y = rw / cw, rh / ch
    ox, oy = (W - rw) // 2, (H - rh) // 2
    occ = np.array(Image.open(os.path.join(ROOT, spec["occluder"])).convert("RGBA"))
    side = int(0.3 * H)
    occ = cv2.resize(occ, (side, side), interpolation=cv2.INTER_AREA)
    names = list(rest)
    frames = np.empty((n, H, W, 3), np.uint8)
    masks = np.empty((n, H, W), bool)
    truth = np.empty((n, len(names), 2))
    visible = np.ones((n, len(names)), bool)
    for i in range(n):
        t = i / max(n - 1, 1)
        pose = {k: f(rest[k], t).tolist() for k, f in spec["paths"].items()}
        layers = scene.layers(pose)
        rgba = scene.draw_layers(layers, size=(rw, rh))
        fg = scene.draw_layers(layers, size=(rw, rh), background=(0, 0, 0, 0))[..., 3]
        bg = np.array(raw.get("background", [255, 255, 255, 255])[:3], np.uint8)
        canvas = np.empty((H, W, 4), np.uint8)
        canvas[:] = (*bg, 0)
        canvas[oy:oy + rh, ox:ox + rw] = rgba
        M = global_motion(name, t, size)
        frame = cv2.warpAffine(canvas[..., :3], M, (W, H), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_CONSTANT, borderValue=tuple(int(c) for c in bg))
        full = np.zeros((H, W), np.uint8)
        full[oy:oy + rh, ox:ox + rw] = fg
        masks[i] = cv2.warpAffine(full, M, (W, H), flags=cv2.INTER_LINEAR) > 127
        P = np.array([pose.get(k, rest[k]) for k in names], float)
        P = np.stack([P[:, 0] * s_x - 0.5 + ox, P[:, 1] * s_y - 0.5 + oy], 1)
        truth[i] = P @ M[:, :2].T + M[:, 2]
        frames[i], cover = _occlude(frame, occ, t, size)
        ij = np.clip(np.round(truth[i]).astype(int), 0, [W - 1, H - 1])
        visible[i] = ~cover[ij[:, 1], ij[:, 0]]
    return Clip(name, frames, {k: truth[:, j] for j, k in enumerate(names)},
                {k: visible[:, j] for j, k in enumerate(names)}, masks)


def _occlude(frame: np.ndarray, occ: np.ndarray, t: float, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Draw the occluder sliding across the middle of the frame; returns (frame, covered (H, W) bool)."""
    W, H = size
    side = occ.shape[0]
    x = int(round(-side + (W + side) * t))
    y = int(round(0.45 * H - side / 2 + 0.15 * H * _wave(t, 1.5)))
    out = frame.copy()
    cover = np.zeros((H, W), bool)
    x0, x1, y0, y1 = max(x, 0), min(x + side, W), max(y, 0), min(y + side, H)
    if x1 <= x0 or y1 <= y0:
        return out, cover
    o = occ[y0 - y:y1 - y, x0 - x:x1 - x]
    a = o[..., 3:4].astype(np.float32) / 255.0
    out[y0:y1, x0:x1] = (o[..., :3] * a + out[y0:y1, x0:x1] * (1 - a) + 0.5).astype(np.uint8)
    cover[y0:y1, x0:x1] = o[..., 3] > 127
    return out, cover
