"""``puppet animate SCENE -o NAME.glb``: glTF 2.0 binary with one mesh per layer and the
frames as morph targets, for 3D engines and viewers (Blender, three.js, Babylon.js,
Godot, Unity through glTFast).

What is written (glTF 2.0 core, plus ``KHR_materials_unlit``):

* one node and one mesh per layer (named after it), under a root node ``puppet``; each
  primitive has ``POSITION`` (the rest mesh), ``TEXCOORD_0``, ``indices`` and one morph
  target per frame (``POSITION`` displacements from the rest mesh; ``extras.targetNames``
  ``frame_00000`` ...); its material is the layer's texture (PNG in the binary chunk),
  unlit, ``alphaMode`` BLEND, double-sided;
* coordinates: x right, y up, one unit per canvas pixel, origin at the middle of the
  canvas's bottom edge (canvas ``(x, y)`` -> ``(x - W/2, H - y)``), and **z = the
  per-vertex depth** (stacking index + pin depth, in stacking units): a depth-tested
  front view puts the nearer layer in front per pixel, as puppet does;
* an orthographic camera looking down -z that frames the canvas;
* one animation ``animation``: per layer node a ``weights`` channel, key *i* at
  ``i / fps`` with frame *i*'s target at weight 1 and the others 0, LINEAR (so between
  two keys the mesh moves linearly from one frame to the next).

Limits: the weights are frames x frames floats per animation (and viewers keep every
target), so at most :data:`MAX_FRAMES` frames; soft edges are alpha-blended by the
viewer, which sorts whole meshes (not fragments): translucent edge pixels of
overlapping layers may be composited in another order than puppet's.
"""
from __future__ import annotations

import io
import json
import struct

import numpy as np

from puppet.anim.sinks import Sink, check_held
from puppet.errors import SceneError

#: Most frames a .glb export takes (its weights grow with frames squared).
MAX_FRAMES = 1000
_FLOAT, _UINT = 5126, 5125
_ARRAY, _ELEMENTS = 34962, 34963


def check_count(job, draw=None) -> None:
    """Refuse more than :data:`MAX_FRAMES` frames, and more frames x vertices than
    :data:`puppet.anim.sinks.MAX_HELD` allows (the format's ``prepare``: before anything
    is solved)."""
    if job.count > MAX_FRAMES:
        raise SceneError(f"-o {job.output!r}: a .glb holds at most {MAX_FRAMES} frames ({job.count} asked; "
                         "its morph weights grow with frames squared): lower --fps or shorten it with --from/--to")
    check_held(job, 3, 120, "a .glb")


def to_gltf(xy: np.ndarray, depth: np.ndarray, canvas) -> np.ndarray:
    """Canvas pixels (n, 2) and depths (n,) -> glTF positions (n, 3) float32."""
    w, h = canvas
    xy = np.asarray(xy, np.float64).reshape(-1, 2)
    return np.stack([xy[:, 0] - w / 2.0, h - xy[:, 1], np.asarray(depth, np.float64).reshape(-1)],
                    axis=1).astype(np.float32)


class _Bin:
    """The binary chunk, its buffer views and accessors."""

    def __init__(self):
        self.data = io.BytesIO()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def view(self, raw: bytes, target: int | None = None) -> int:
        pad = (-self.data.tell()) % 4
        self.data.write(b"\0" * pad)
        v = {"buffer": 0, "byteOffset": self.data.tell(), "byteLength": len(raw)}
        if target is not None:
            v["target"] = target
        self.data.write(raw)
        self.views.append(v)
        return len(self.views) - 1

    def accessor(self, a: np.ndarray, kind: str, target: int | None = None, bounds: bool = False) -> int:
        ctype = _UINT if a.dtype == np.uint32 else _FLOAT
        acc = {"bufferView": self.view(np.ascontiguousarray(a).tobytes(), target), "componentType": ctype,
               "count": int(a.shape[0]), "type": kind}
        if bounds:  # required for POSITION (targets too)
            acc["min"] = [float(v) for v in a.min(axis=0)] if len(a) else [0.0] * a.shape[1]
            acc["max"] = [float(v) for v in a.max(axis=0)] if len(a) else [0.0] * a.shape[1]
        self.accessors.append(acc)
        return len(self.accessors) - 1


class GltfSink(Sink):
    """Collects each frame's displacements; writes the .glb to ``job.tmp`` when closed."""

    def __init__(self, job):
        super().__init__()
        check_count(job)
        self.job = job
        self.canvas = job.scene.canvas
        self.rest = None
        self.targets: list[list[np.ndarray]] = []

    def add(self, layers) -> None:
        if self.rest is None:
            self.rest = [(np.asarray(r.rest, np.float64), np.asarray(r.triangles, np.uint32).reshape(-1, 3),
                          to_gltf(r.rest, np.full(len(r.rest), float(r.order)), self.canvas)) for r in layers]
            self.names = [r.name for r in layers]
            self.targets = [[] for _ in layers]
        for k, r in enumerate(layers):
            self.targets[k].append(to_gltf(r.deformed, r.depth, self.canvas) - self.rest[k][2])
        self.frames += 1

    def close(self) -> None:
        if self.rest is None:
            raise ValueError("no frames")
        doc, blob = self._document()
        text = json.dumps(doc, separators=(",", ":")).encode()
        text += b" " * ((-len(text)) % 4)
        blob += b"\0" * ((-len(blob)) % 4)
        with open(self.job.tmp, "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + 8 + len(blob)))
            f.write(struct.pack("<I4s", len(text), b"JSON") + text)
            f.write(struct.pack("<I4s", len(blob), b"BIN\0") + blob)

    def _document(self) -> tuple[dict, bytes]:
        from PIL import Image

        b = _Bin()
        n = self.frames
        meshes, nodes, materials, textures, images = [], [], [], [], []
        for k, (name, (rest, tri, base), image) in enumerate(zip(self.names, self.rest, self.job.scene.built.images)):
            crop, offset = image.drawn
            h, w = crop.shape[:2]
            png = io.BytesIO()
            Image.fromarray(np.ascontiguousarray(crop), "RGBA").save(png, format="PNG")
            images.append({"bufferView": b.view(png.getvalue()), "mimeType": "image/png", "name": name})
            textures.append({"sampler": 0, "source": k})
            materials.append({"name": name, "doubleSided": True, "alphaMode": "BLEND",
                              "pbrMetallicRoughness": {"baseColorTexture": {"index": k}, "metallicFactor": 0.0,
                                                       "roughnessFactor": 1.0},
                              "extensions": {"KHR_materials_unlit": {}}})
            uv = ((rest - offset) / (w, h)).astype(np.float32)
            prim = {"attributes": {"POSITION": b.accessor(base, "VEC3", _ARRAY, bounds=True),
                                   "TEXCOORD_0": b.accessor(uv, "VEC2", _ARRAY)},
                    "indices": b.accessor(tri.reshape(-1), "SCALAR", _ELEMENTS), "material": k, "mode": 4,
                    "targets": [{"POSITION": b.accessor(t, "VEC3", _ARRAY, bounds=True)} for t in self.targets[k]]}
            meshes.append({"name": name, "primitives": [prim], "weights": [0.0] * n,
                           "extras": {"targetNames": [f"frame_{i:05d}" for i in range(n)]}})
            nodes.append({"name": name, "mesh": k})
        times = b.accessor((np.arange(n, dtype=np.float32) / np.float32(self.job.fps)).reshape(-1, 1), "SCALAR",
                           bounds=True)
        weights = b.accessor(np.eye(n, dtype=np.float32).reshape(-1), "SCALAR")
        W, H = self.canvas
        nodes.append({"name": "camera", "camera": 0, "translation": [0.0, H / 2.0, 1000.0]})
        shown = [k for k, L in enumerate(self.job.scene.data.layers) if L.visible]  # a hidden layer's node: not in the scene
        nodes.append({"name": "puppet", "children": shown})
        doc = {
            "asset": {"version": "2.0", "generator": "puppet animate"},
            "extensionsUsed": ["KHR_materials_unlit"],
            "scene": 0, "scenes": [{"name": "puppet", "nodes": [len(nodes) - 1, len(nodes) - 2]}],
            "nodes": nodes, "meshes": meshes, "materials": materials, "textures": textures, "images": images,
            "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}],
            "cameras": [{"type": "orthographic", "name": "canvas",
                         "orthographic": {"xmag": W / 2.0, "ymag": H / 2.0, "znear": 0.01, "zfar": 2000.0}}],
            "animations": [{"name": "animation",
                            "samplers": [{"input": times, "output": weights, "interpolation": "LINEAR"}],
                            "channels": [{"sampler": 0, "target": {"node": k, "path": "weights"}}
                                         for k in range(len(self.names))]}],
            "accessors": b.accessors, "bufferViews": b.views,
        }
        blob = b.data.getvalue()
        doc["buffers"] = [{"byteLength": len(blob)}]
        return doc, blob
