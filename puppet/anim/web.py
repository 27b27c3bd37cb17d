"""``puppet animate SCENE -o NAME.html``: one self-contained HTML file that plays the
animation in a browser with a small WebGL2 player (:file:`player.js`, in this package).

Nothing is referenced outside the file: every layer's texture is a PNG data URI (the
cropped image the compositor uploads, see :attr:`puppet.scene.rig.build.LayerImage.drawn`)
and the frames are puppet's solved meshes (in-betweens included), so the page needs no
solver. They are stored as keys: per layer, the frames on the scene's keys and those
that interpolation in the page (linear, or a Bezier curve, as Spine's runtimes compute
it: :mod:`puppet.anim.keys`) needs to give every frame within ``--tolerance`` pixels
(default 1; 0: every frame stored) and its depths within :data:`DEPTH_TOLERANCE`; the
page computes the other frames when it loads.

Layout of the page: ``#puppet-meta`` (JSON: canvas, fps, layers with their texture,
texture coordinates as float32 and triangles as uint32, all base64) and
``#puppet-frames`` (base64 of key records of the layers the page draws, each a multiple of 3 bytes, so the records
encode to base64 one at a time without padding: int32 layer, int32 frame, float32
``cx1, cy1, cx2, cy2`` of the curve to the layer's next key (NaN: linear), then the
layer's int16 codes at that frame: its x, y (interleaved), then its depths). Records are
written as each span between the scene's keys (at most :data:`SPAN` frames) is planned:
memory is bounded by the span, not by the frame count.

Quantisation (see :func:`quantisation`): positions are int16 over the canvas widened by
one canvas on each side (``3 W / 65534`` px a step: 0.032 px at 700 px), clamped
beyond; depths are int16 in steps of ``2**-k`` stacking units, k the largest that holds
+/-(layers + 64). An in-between is rounded to the nearest code.
"""
from __future__ import annotations

import base64
import dataclasses
import html
import io
import json
import math
import os
import re
import struct
from importlib import resources

import numpy as np

from puppet.anim.keys import SPAN, plan, scene_frames
from puppet.anim.sinks import Sink
from puppet.render.layers import classify_triangles

#: int16 codes used (symmetric: -Q..Q).
Q = 32767
#: Largest depth error of an in-between computed in the page, stacking units (a layer's
#: stacking distance is 1).
DEPTH_TOLERANCE = 0.05
#: Bytes of a key record's header: int32 layer, int32 frame, 4 float32 of the curve.
HEADER = struct.Struct("<ii4f")


def quantisation(canvas: tuple[int, int], layers: int) -> tuple[tuple[float, float, float, float], float]:
    """((step x, step y, centre x, centre y), depth step) of the int16 codes.

    A position p is stored as ``round((p - centre) / step)`` clamped to +/-:data:`Q`:
    the canvas widened by its own size on every side fits.
    """
    w, h = (float(v) for v in canvas)
    sx, sy = 3.0 * w / (2 * Q), 3.0 * h / (2 * Q)
    k = math.floor(math.log2(Q / (layers + 64)))
    return (sx, sy, w / 2.0, h / 2.0), 2.0 ** -k


def encode_frame(layers, quant, depth_step: float) -> bytes:
    """One frame's int16 codes: every layer's x, y (interleaved), then every depth.

    Parameters
    ----------
    layers : list of LayerResult (``deformed`` (n, 2), ``depth`` (n,)).
    """
    sx, sy, cx, cy = quant
    xy = np.concatenate([np.asarray(r.deformed, np.float64).reshape(-1, 2) for r in layers])
    d = np.concatenate([np.asarray(r.depth, np.float64).reshape(-1) for r in layers])
    q = np.empty((len(xy) * 3,), np.int16)
    qxy = np.rint((xy - (cx, cy)) / (sx, sy))
    q[: 2 * len(xy)] = np.clip(qxy, -Q, Q).reshape(-1)
    q[2 * len(xy):] = np.clip(np.rint(d / depth_step), -Q, Q)
    return q.astype("<i2").tobytes()


def png_bytes(rgba: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgba), "RGBA").save(buf, format="PNG", optimize=False, compress_level=9)
    return buf.getvalue()


def png_uri(rgba: np.ndarray) -> str:
    return "data:image/png;base64," + base64.b64encode(png_bytes(rgba)).decode("ascii")


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype).tobytes()).decode("ascii")


def layer_entry(result, image: np.ndarray, offset, base: int, visible: bool = True) -> dict:
    """The static part of one layer: texture, texture coordinates, triangles (the
    non-empty ones, then the edge ones, as the compositor's two passes draw them). A
    hidden layer (``visible`` False) keeps its place in the frames' vertices but has no
    triangle to draw and a one-pixel texture."""
    if not visible:
        image, result = np.zeros((1, 1, 4), np.uint8), dataclasses.replace(result, triangles=np.zeros((0, 3), np.int64))
    h, w = image.shape[:2]
    uv = (np.asarray(result.rest, np.float64) - offset) / (w, h)
    tri = np.asarray(result.triangles, np.int64).reshape(-1, 3)
    edge, empty = classify_triangles(image, uv, tri)
    drawn, edges = tri[~empty], tri[edge]
    return {"name": result.name, "base": base, "n": len(uv), "opaque": len(drawn), "edge": len(edges),
            "texture": png_uri(image), "uv": _b64(uv, "<f4"),
            "triangles": _b64(np.concatenate([drawn, edges]).reshape(-1), "<u4")}


#: What JSON inside a ``<script>`` element must not hold as it is: ``<`` (no ``</script>``,
#: ``<!--`` or ``<script`` can start there), ``>`` and ``&`` (for good measure), and the
#: line separators that older JavaScript parsers end a string at.
_SCRIPT_JSON = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028", "\u2029": "\\u2029"}
_FIELD = re.compile(r"\{\{(\w+)\}\}")


def script_json(value) -> str:
    """``value`` as JSON that is safe as the text of a ``<script>`` element: the
    characters of :data:`_SCRIPT_JSON` as ``\\uXXXX`` escapes (the same value to a JSON
    parser), so no layer name can end the element or switch the HTML parser into its
    escaped script states (``<!--<script>``)."""
    text = json.dumps(value, separators=(",", ":"))
    return re.sub("[<>&\u2028\u2029]", lambda m: _SCRIPT_JSON[m.group(0)], text)


def script_code(text: str) -> str:
    """Program text (the player) for a ``<script>`` element: it must not hold ``</script``,
    ``<script`` or ``<!--``, which would end the element or change how HTML reads it
    (it is puppet's own file: a ValueError, not a user error)."""
    found = re.search(r"</?script|<!--", text, re.IGNORECASE)
    if found:
        raise ValueError(f"the player holds {found.group(0)!r}, which cannot appear inside <script>")
    return text


def utf8(name: str) -> str:
    """A file name as text the page can hold: bytes that are not UTF-8 (kept by Python as
    lone surrogates) become U+FFFD."""
    try:
        return name.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    except UnicodeEncodeError:
        return name.encode("utf-8", "replace").decode("utf-8")


def fill(template: str, values: dict[str, str]) -> str:
    """Replace every ``{{name}}`` of ``template`` in one pass: a value is never read again
    for fields (a scene named ``{{meta}}.json`` stays its name)."""
    return _FIELD.sub(lambda m: values[m.group(1)], template)


def _background(bg) -> tuple[list[float], str]:
    """(clear colour, straight RGBA 0..1; CSS background of the canvas)."""
    if isinstance(bg, np.ndarray) and bg.ndim == 3:
        return [0.0, 0.0, 0.0, 0.0], f"background: url({png_uri(bg)}) 0 0 / 100% 100% no-repeat;"
    return [float(v) / 255.0 for v in bg], ""


class HtmlSink(Sink):
    """Writes the page to ``job.tmp`` as frames come (solved layers, not pixels): the
    frames since the last key are held (int16 codes) until the next scene key, or
    :data:`SPAN` frames, or the last frame; then each layer's keys up to there are planned
    and written."""

    def __init__(self, job):
        super().__init__()
        self.job = job
        self.fp = open(job.tmp, "w", encoding="utf-8")
        self.quant = self.depth_step = None
        self.held: list[np.ndarray] = []  # codes of the frames from the span's first key on
        self.first = 0  # the frame of held[0]
        self.forced = set(scene_frames(job.scene.data.animation, job.start, job.fps, job.count))

    def _head(self, layers) -> None:
        job, scene = self.job, self.job.scene
        self.quant, self.depth_step = quantisation(scene.canvas, len(layers))
        entries, base = [], 0
        for r, im, L in zip(layers, scene.built.images, scene.data.layers):
            image, offset = im.drawn
            entries.append(layer_entry(r, image, offset, base, L.visible))
            base += len(r.rest)
        self.spans = [(e["base"], e["n"]) for e in entries]
        # the page draws, and reads the frames of, only layers with opaque triangles (a
        # hidden layer has none): the others get no keys
        self.drawn = [i for i, e in enumerate(entries) if e["opaque"]]
        self.nv = base
        clear, css = _background(job.background)
        meta = {"puppet": 2, "canvas": list(scene.canvas), "size": list(job.size), "fps": job.fps,
                "start": job.start, "count": job.count, "vertices": base, "quant": list(self.quant),
                "depthStep": self.depth_step, "background": clear, "layers": entries}
        title = html.escape(utf8(os.path.basename(scene.file or "puppet")))
        page = resources.files("puppet.anim").joinpath("player.html").read_text("utf-8")
        head, self.tail = page.split("{{frames}}")
        w, h = job.size
        self.fp.write(fill(head, {"title": title, "width": str(int(w)), "height": str(int(h)), "canvas_css": css,
                                  "meta": script_json(meta)}))

    def add(self, layers) -> None:
        if self.quant is None:
            self._head(layers)
        self.held.append(np.frombuffer(encode_frame(layers, self.quant, self.depth_step), "<i2"))
        f = self.frames
        self.frames += 1
        if f > self.first and (f in self.forced or f == self.job.count - 1 or f - self.first >= SPAN):
            self._flush()

    def _layer(self, q: np.ndarray, i: int) -> np.ndarray:
        """Layer ``i``'s frames of the codes ``q`` (frames, 3 x vertices) as (frames, n,
        3): x, y in pixels and depth scaled so that :data:`DEPTH_TOLERANCE` counts as the
        tolerance."""
        b, n = self.spans[i]
        sx, sy = self.quant[:2]
        depth = q[:, 2 * self.nv + b:2 * self.nv + b + n] * (self.depth_step * self.job.tolerance / DEPTH_TOLERANCE)
        return np.concatenate([q[:, 2 * b:2 * (b + n)].reshape(len(q), n, 2) * (sx, sy), depth[..., None]], axis=2)

    def _flush(self) -> None:
        """Plan each layer's keys over the held span, write all but its last frame (the
        next span's first), keep that frame."""
        m = len(self.held)
        T = np.arange(self.first, self.first + m) / self.job.fps
        tol = self.job.tolerance - 2 * max(self.quant[:2])  # a code's rounding, twice
        q = np.stack(self.held)
        for i in self.drawn:  # (a tolerance of 0 or less: every frame, linear)
            for k in plan(self._layer(q, i), T, [], tol)[:-1]:
                self._record(i, k.frame, k.curve)
        self.first += m - 1
        self.held = self.held[-1:]

    def _record(self, i: int, f: int, curve) -> None:
        """Write layer ``i``'s key at held frame ``f`` with its curve (None: linear)."""
        b, n = self.spans[i]
        q = self.held[f]
        head = HEADER.pack(i, self.first + f, *(curve if curve is not None else (math.nan,) * 4))
        body = np.concatenate([q[2 * b:2 * (b + n)], q[2 * self.nv + b:2 * self.nv + b + n]]).astype("<i2")
        self.fp.write(base64.b64encode(head + body.tobytes()).decode("ascii"))
        self.fp.write("\n")

    def close(self) -> None:
        try:
            if self.quant is None:
                raise ValueError("no frames")
            if len(self.held) > 1:
                self._flush()
            for i in self.drawn:  # every layer's last key: the last frame
                self._record(i, 0, None)
            script = resources.files("puppet.anim").joinpath("player.js").read_text("utf-8")
            self.fp.write(fill(self.tail, {"player": script_code(script)}))
        finally:
            self.fp.close()

    def abort(self) -> None:
        self.fp.close()
