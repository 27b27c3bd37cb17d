"""``puppet animate SCENE -o NAME.spine.json`` (or ``-o NAME.json --format spine``):
the animation as Spine 4.2 skeleton JSON, with its libgdx text atlas ``NAME.atlas`` and
page image(s) ``NAME.png`` (``NAME_2.png`` ...), for the Spine runtimes of game engines.

What is written (keys as in Esoteric Software's "JSON export format" page):

* ``skeleton``: ``spine`` 4.2.0, bounds of the setup pose, ``fps``, ``images``;
* ``bones``: one ``root`` at the origin;
* ``slots``: one per layer, named after it, in stacking order (back first), each
  showing its layer's attachment;
* ``skins``: ``default`` with one unweighted ``mesh`` per layer: ``uvs`` (0..1 over the
  layer's region, v down), ``vertices`` (the rest mesh), ``triangles``, ``hull`` (the
  outer boundary loop's vertices come first, in order), ``edges`` (every mesh edge,
  vertex index x 2), ``width``/``height`` of the region;
* ``animations``: ``animation`` (the scene's, from --from) with a ``deform`` timeline per
  moving layer (offsets from the setup vertices): a key at every frame on a scene key
  and at the frames the runtimes' interpolation (linear, or the key's Bezier ``curve``)
  needs to replay every frame within ``--tolerance`` (1 px; :mod:`puppet.anim.keys`;
  0: a key on every frame, linear), and a ``drawOrder`` key wherever the layers' order
  by mean depth changes; and one animation per named pose, a single key at time 0.

Coordinates: Spine's y axis points up. A canvas point (x, y) (pixels, y down, origin at
the top-left) is ``(x - W / 2, H - y)`` in Spine: the skeleton's origin is the
middle of the canvas's bottom edge.

Not expressible: per-vertex depth inside one layer (a layer is drawn whole, in the
draw order, so a limb cannot pass behind the body and in front again within one frame;
the draw order follows each layer's mean depth), holes and separate pieces of one layer
(Spine meshes have one outline: the longest boundary loop is the hull, the other loops'
vertices follow as ordinary vertices; the triangles still draw them), the background.

Memory: the deform offsets of every frame are held until the JSON is written (the keys
are chosen from all of them): frames x vertices x 8 bytes as float32 (one array a
frame), then each layer's timeline as JSON text (the file's text is never made as one
string); frames x (vertices x 2 + layers x 4) is bounded by
:data:`puppet.anim.sinks.MAX_HELD`, refused before any frame is solved.
"""
from __future__ import annotations

import base64
import hashlib
import io
import json
import os
import re
import uuid

import numpy as np

from puppet.anim.keys import Key, plan, scene_frames
from puppet.anim.sheet import write_png
from puppet.anim.sidefiles import spine_side
from puppet.anim.simplify import coarser
from puppet.anim.sinks import Sink, check_held, stage_bytes
from puppet.errors import SceneError
from puppet.geom.mesh import boundary_edges, edges
from puppet.output import check_file

SPINE_VERSION = "4.2.0"
#: Largest atlas page side; more pages are made when the layers do not fit in one.
PAGE_SIDE = 4096
#: Pixels between regions on a page (and around them).
PAD = 2
#: Decimals of vertices and offsets (0.005 px at most off).
DECIMALS = 2
#: zlib level of the atlas pages.
PNG_LEVEL = 6
#: Pixels the rounding of written vertices and offsets may add to a replayed vertex
#: (the setup vertex and the interpolated offset, each within 0.005 px per axis).
ROUNDING = 0.015


def page_path(path: str, k: int) -> str:
    """Atlas page ``k`` beside ``NAME.json``: ``NAME.png``, ``NAME_2.png``, ..."""
    stem = spine_side(path)[1][:-4]
    return f"{stem}.png" if k == 0 else f"{stem}_{k + 1}.png"


def check_size(job, draw=None) -> None:
    """The format's ``prepare``: refuse more frames x vertices than
    :data:`puppet.anim.sinks.MAX_HELD` allows, before anything is solved."""
    check_held(job, 2, 4, "a Spine file")


def to_spine(xy: np.ndarray, canvas) -> np.ndarray:
    """Canvas pixels (n, 2), y down -> Spine (n, 2), y up, origin at the bottom middle."""
    w, h = canvas
    xy = np.asarray(xy, np.float64).reshape(-1, 2)
    return np.stack([xy[:, 0] - w / 2.0, h - xy[:, 1]], axis=1)


def hull_first(triangles: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """A vertex order with the outer boundary loop first.

    Parameters
    ----------
    triangles : (m, 3) int
    n : number of vertices.

    Returns
    -------
    perm : (n,) int64
        New position -> old vertex index: the longest boundary loop (in its order), then
        every other vertex in its old order.
    hull : int
        Length of that loop (0 when the mesh has no boundary).
    """
    nxt: dict[int, list[int]] = {}
    for a, b in boundary_edges(np.asarray(triangles, np.int64).reshape(-1, 3)).tolist():
        nxt.setdefault(a, []).append(b)
    seen: set[int] = set()
    best: list[int] = []
    for start in sorted(nxt):
        if start in seen:
            continue
        loop, v = [], start
        while v in nxt and v not in seen:
            seen.add(v)
            loop.append(v)
            v = nxt[v][0]
        if len(loop) > len(best):
            best = loop
    rest = np.setdiff1d(np.arange(n), best, assume_unique=False)
    return np.concatenate([np.asarray(best, np.int64), rest]).astype(np.int64), len(best)


def pack(sizes: list[tuple[int, int]], side: int = PAGE_SIDE, pad: int = PAD) -> list[tuple[int, int, int]]:
    """Shelf packing: (page, x, y) of each (w, h) box, tallest first, ``pad`` pixels apart.

    Raises ValueError for a box larger than a page.
    """
    place: list[tuple[int, int, int] | None] = [None] * len(sizes)
    page, x, y, shelf = 0, pad, pad, 0
    for i in sorted(range(len(sizes)), key=lambda i: (-sizes[i][1], -sizes[i][0], i)):
        w, h = sizes[i]
        if w + 2 * pad > side or h + 2 * pad > side:
            raise ValueError(f"a {w}x{h} layer does not fit on a {side}x{side} atlas page")
        if x + w + pad > side:  # next shelf
            x, y, shelf = pad, y + shelf + pad, 0
        if y + h + pad > side:  # next page
            page, x, y, shelf = page + 1, pad, pad, 0
        place[i] = (page, x, y)
        x, shelf = x + w + pad, max(shelf, h)
    return place  # type: ignore[return-value]


def region_names(names: list[str]) -> list[str]:
    """Atlas region names: no colon or line break (the atlas is ``key: value`` lines), no
    lone surrogate (the atlas is UTF-8 text), no outer spaces, unique."""
    out, used = [], set()
    for name in names:
        base = re.sub("[:\r\n\ud800-\udfff]+", "_", name).strip() or "layer"
        cand, k = base, 2
        while cand in used:
            cand, k = f"{base}_{k}", k + 1
        used.add(cand)
        out.append(cand)
    return out


def draw_order(layers, slot_of: list[int]) -> list[int]:
    """Slot indices from back to front by each layer's mean depth (ties: stacking order).

    ``slot_of[i]`` is the slot of ``layers[i]``.
    """
    key = [(float(np.mean(r.depth)) if len(r.depth) else 0.0, slot_of[i]) for i, r in enumerate(layers)]
    return [slot_of[i] for i in sorted(range(len(layers)), key=lambda i: key[i])]


def order_offsets(order: list[int], names: list[str]) -> list[dict] | None:
    """A ``drawOrder`` key's ``offsets`` for ``order`` (slot indices, back first), or None
    for the setup order: each moved slot, in setup order, with its position change."""
    pos = {s: p for p, s in enumerate(order)}
    moved = [{"slot": names[s], "offset": pos[s] - s} for s in range(len(order)) if pos[s] != s]
    return moved or None


def _r(a: np.ndarray) -> list[float]:
    return [float(v) for v in np.round(np.asarray(a, np.float64).reshape(-1), DECIMALS)]


class _Held:
    """Deform timelines as JSON text, kept apart from the document: in the document each
    is a marker string, which :meth:`parts` swaps for the timeline's text (the text of the
    whole file is never made as one string)."""

    def __init__(self):
        self.token = f"puppet-timeline-{uuid.uuid4().hex}-"
        self.timelines: list[str] = []

    def add(self, keys: list[str]) -> str:
        """Keep the timeline of these keys (JSON texts) as one string; its marker."""
        self.timelines.append("[" + ",".join(keys) + "]")
        return f"{self.token}{len(self.timelines) - 1}"

    def parts(self, text: str):
        """The pieces of the document ``text`` (JSON) with every marker replaced, in order."""
        for k, piece in enumerate(re.split(f'"{re.escape(self.token)}(\\d+)"', text)):
            if k % 2 == 0:
                yield piece
            else:
                yield self.timelines[int(piece)]


class _Offsets:
    """Deform offsets, one float32 (vertices, 2) array a frame for every layer together
    (no array object per layer and frame); :meth:`layer` gives one layer's frames."""

    def __init__(self, starts: list[int]):
        self.starts = starts  # layer i is rows starts[i]:starts[i + 1]
        self.frames: list[np.ndarray] = []

    def append(self, offs: list[np.ndarray]) -> None:
        self.frames.append(np.concatenate(offs) if offs else np.zeros((0, 2), np.float32))

    def layer(self, i: int) -> list[np.ndarray]:
        a, b = self.starts[i], self.starts[i + 1]
        return [f[a:b] for f in self.frames]


class SpineSink(Sink):
    """Collects each frame's deform offsets and draw order; writes the JSON (to
    ``job.tmp``), the atlas and its pages when closed."""

    def __init__(self, job):
        super().__init__()
        self.job = job
        scene = job.scene
        self.canvas = scene.canvas
        rest = scene.layers(pose="rest")
        self.names = [r.name for r in rest]
        # slots in stacking order (the layer's `order`, then its list position)
        self.slots = sorted(range(len(rest)), key=lambda i: (rest[i].order, i))
        self.slot_of = [self.slots.index(i) for i in range(len(rest))]
        self.regions = region_names([self.names[i] for i in self.slots])
        self.perm, self.hulls = [], []
        for r in rest:
            perm, hull = hull_first(r.triangles, len(r.rest))
            self.perm.append(perm)
            self.hulls.append(hull)
        self.rest_xy = [np.asarray(r.rest, np.float64) for r in rest]
        self.triangles = [np.asarray(r.triangles, np.int64).reshape(-1, 3) for r in rest]
        self.setup = [to_spine(xy[p], self.canvas) for xy, p in zip(self.rest_xy, self.perm)]
        self.keys = _Offsets(np.concatenate([[0], np.cumsum([len(r.rest) for r in rest])]).astype(int).tolist())
        self.orders: list[list[int]] = []
        crops = [scene.built.images[i].drawn[0] for i in self.slots]
        try:
            self.place = pack([(c.shape[1], c.shape[0]) for c in crops], side=PAGE_SIDE)
        except ValueError as e:  # before any frame is solved
            raise SceneError(f"-o {job.output!r}: {e}; Spine atlas pages are at most {PAGE_SIDE} px") from None
        for k in range(1 + max((p for p, _, _ in self.place), default=0)):  # before any frame is solved
            check_file(page_path(job.output, k), inputs=job.inputs, follow=False)
        self.poses = {name: self._pose(scene.layers(pose=name)) for name in scene.data.poses}

    def _pose(self, layers) -> tuple[list[np.ndarray], list[int]]:
        offs = [(to_spine(np.asarray(r.deformed)[p], self.canvas) - s).astype(np.float32)
                for r, p, s in zip(layers, self.perm, self.setup)]
        return offs, draw_order(layers, self.slot_of)

    def add(self, layers) -> None:
        offs, order = self._pose(layers)
        self.keys.append(offs)
        if self.orders and order == self.orders[-1]:
            order = self.orders[-1]  # one list for a run of frames in the same order
        self.orders.append(order)
        self.frames += 1

    # -- writing -------------------------------------------------------------------
    def _keys(self, frames: list[np.ndarray], times: np.ndarray, forced: list[int]) -> list[Key]:
        """The deform keys of one layer's offsets (see :mod:`puppet.anim.keys`): within
        the tolerance less what rounding the written values may add."""
        if len(frames) < 3 or self.job.tolerance <= 0:
            return [Key(f) for f in range(len(frames))]
        return plan(np.stack(frames).astype(np.float64), times, forced, self.job.tolerance - ROUNDING)

    def _animation(self, keys: _Offsets, orders: list[list[int]], held: _Held) -> dict:
        """One animation; each deform timeline is JSON text kept in ``held`` (made a key
        at a time: no float objects for every frame), its place in the dict a marker."""
        fps = self.job.fps
        slot_names = [self.names[i] for i in self.slots]
        deform: dict = {}
        times = np.arange(len(keys.frames)) / fps
        forced = scene_frames(self.job.scene.data.animation, self.job.start, fps, len(keys.frames))
        for i in self.slots:
            frames = keys.layer(i)
            if not any(np.any(np.abs(f) >= 0.5 * 10.0 ** -DECIMALS) for f in frames):
                continue  # never moves: no timeline
            region = self.regions[self.slot_of[i]]
            timeline = []
            for k in self._keys(frames, times, forced):
                key: dict = {"time": round(k.frame / fps, 6)}
                off = frames[k.frame]
                if np.any(np.abs(off) >= 0.5 * 10.0 ** -DECIMALS):
                    key["vertices"] = _r(off)
                if k.curve is not None:
                    key["curve"] = list(k.curve)
                timeline.append(json.dumps(key, separators=(",", ":")))
            deform[self.names[i]] = {region: {"deform": held.add(timeline)}}
        anim: dict = {}
        if deform:
            anim["attachments"] = {"default": deform}
        draw, last = [], list(range(len(self.slots)))
        for f, order in enumerate(orders):
            if order != last:
                key = {"time": round(f / fps, 6)}
                offsets = order_offsets(order, slot_names)
                if offsets:
                    key["offsets"] = offsets
                draw.append(key)
                last = order
        if draw:
            anim["drawOrder"] = draw
        return anim

    def _skin(self, layers_images) -> dict:
        out = {}
        for i in self.slots:
            image, offset = layers_images[i]
            h, w = image.shape[:2]
            perm = self.perm[i]
            rest = self.rest_xy[i][perm]
            uv = (rest - offset) / (w, h)
            inverse = np.empty_like(perm)
            inverse[perm] = np.arange(len(perm))
            tri = inverse[self.triangles[i]]
            mesh = {"type": "mesh", "uvs": [float(v) for v in np.round(uv.reshape(-1), 6)],
                    "triangles": tri.reshape(-1).tolist(), "vertices": _r(self.setup[i]),
                    "hull": int(self.hulls[i]), "edges": (edges(tri) * 2).reshape(-1).tolist() if len(tri) else [],
                    "width": int(w), "height": int(h)}
            region = self.regions[self.slot_of[i]]
            out[self.names[i]] = {region: mesh}
        return {"name": "default", "attachments": out}

    def _simplify(self) -> None:
        """Each layer's mesh swapped for a coarser one where that draws every frame and
        pose within ``--simplify`` pixels of puppet's (:mod:`puppet.anim.simplify`), its
        offsets carried over (``W`` keeps offsets: its rows sum to one)."""
        poses = list(self.poses)
        frames = [np.concatenate([np.stack(self.keys.layer(i))] + [self.poses[p][0][i][None] for p in poses])
                  for i in range(len(self.perm))]
        for i, F in enumerate(frames):
            perm = self.perm[i]
            inverse = np.empty_like(perm)
            inverse[perm] = np.arange(len(perm))
            c = coarser(self.job.scene, i, self.rest_xy[i][perm], inverse[self.triangles[i]], F, self.job.simplify)
            if c is None:
                continue
            cperm, self.hulls[i] = hull_first(c.F, len(c.V))
            self.perm[i], self.rest_xy[i], self.triangles[i] = cperm, c.V, c.F
            self.setup[i] = to_spine(c.V[cperm], self.canvas)
            frames[i] = (c.W[cperm] @ F.reshape(len(F), -1, 2).transpose(1, 0, 2).reshape(len(perm), -1)) \
                .reshape(len(cperm), len(F), 2).transpose(1, 0, 2).astype(np.float32)
        starts = np.concatenate([[0], np.cumsum([len(s) for s in self.setup])]).astype(int).tolist()
        m = len(self.keys.frames)
        self.keys = _Offsets(starts)
        for f in range(m):
            self.keys.append([F[f] for F in frames])
        self.poses = {p: ([F[m + j] for F in frames], self.poses[p][1]) for j, p in enumerate(poses)}

    def close(self) -> None:
        images = [im.drawn for im in self.job.scene.built.images]
        if self.job.simplify:
            self._simplify()
        held = _Held()
        anims = {"animation": self._animation(self.keys, self.orders, held)}
        for name, (offs, order) in self.poses.items():
            pose = _Offsets(self.keys.starts)
            pose.append(offs)
            anims[name if name not in anims else f"pose_{name}"] = self._animation(pose, [order], held)
        allxy = np.concatenate([s for s in self.setup if len(s)]) if any(len(s) for s in self.setup) \
            else np.zeros((1, 2))
        lo, hi = allxy.min(axis=0), allxy.max(axis=0)
        body = {
            "bones": [{"name": "root"}],
            # a hidden layer (`visible: false`) has its attachment in the skin but none shown
            "slots": [{"name": self.names[i], "bone": "root",
                       **({"attachment": self.regions[self.slot_of[i]]} if self.job.scene.data.layers[i].visible
                          else {})} for i in self.slots],
            "skins": [self._skin(images)],
            "animations": anims,
        }
        text = json.dumps(body, separators=(",", ":"))  # the C encoder (json.dump is pure Python)
        sha = hashlib.sha1()
        for part in held.parts(text):
            sha.update(part.encode())
        digest = base64.b64encode(sha.digest())[:11].decode("ascii")
        skeleton = {"hash": digest, "spine": SPINE_VERSION, "x": round(float(lo[0]), 2), "y": round(float(lo[1]), 2),
                    "width": round(float(hi[0] - lo[0]), 2), "height": round(float(hi[1] - lo[1]), 2),
                    "fps": self.job.fps, "images": "./", "audio": ""}
        with open(self.job.tmp, "w", encoding="utf-8") as f:
            f.write('{"skeleton":' + json.dumps(skeleton, separators=(",", ":")) + ",")
            parts = held.parts(text)
            f.write(next(parts)[1:])
            for part in parts:
                f.write(part)
        self._write_atlas(images)

    def _write_atlas(self, images) -> None:
        out = self.job.output
        crops, place = [images[i][0] for i in self.slots], self.place
        pages = 1 + max((p for p, _, _ in place), default=0)
        lines = []
        for k in range(pages):
            mine = [j for j, p in enumerate(place) if p[0] == k]
            w = max(place[j][1] + crops[j].shape[1] for j in mine) + PAD
            h = max(place[j][2] + crops[j].shape[0] for j in mine) + PAD
            sheet = np.zeros((h, w, 4), np.uint8)
            for j in mine:
                _, x, y = place[j]
                ch, cw = crops[j].shape[:2]
                sheet[y:y + ch, x:x + cw] = crops[j]
            path = page_path(out, k)
            png = io.BytesIO()
            write_png(png, sheet, PNG_LEVEL)
            stage_bytes(self.job.staged, path, png.getvalue(), self.job.inputs)
            lines += [os.path.basename(path), f"\tsize: {w}, {h}", "\tfilter: Linear, Linear", "\tpma: false"]
            for j in mine:
                _, x, y = place[j]
                lines += [self.regions[j], f"\tbounds: {x}, {y}, {crops[j].shape[1]}, {crops[j].shape[0]}"]
            lines.append("")
        stage_bytes(self.job.staged, spine_side(out)[0], "\n".join(lines).encode("utf-8"), self.job.inputs)
