"""Template (garment) mode: carry a template garment's pins and poses over to another
picture of the same kind of garment.

The template is a scene whose one layer (or the layer named by ``layer``) is a garment
with pins and poses. For each new picture, :func:`transfer`:

1. segments the picture the way the template's layer is segmented (its ``alpha`` or
   ``threshold`` mask rule; the default rule when the template uses the default or a
   rule tied to its own pixels: polygon, rect, grabcut, mask file);
2. takes the outer outline of the largest component of both masks, aligns the
   template's onto the picture's by a similarity and corresponds them by arc length
   between matched curvature landmarks (sleeve ends, armpits, hem corners):
   :func:`puppet.geom.outline_corr.match_outlines`;
3. scores the match: symmetric mean distance between the aligned outlines under that
   correspondence, over ``sqrt(area)`` of the picture's outline; above ``tolerance``
   the picture is refused with :class:`NoMatch` (the message says by how much);
4. moves each pin: a pin on or outside the outline (within 1.5 px, or an exterior pin)
   goes to the corresponding outline point, offset by its scaled offset in the local
   (tangent, normal) frame; an interior pin keeps its mean value coordinates relative
   to the outline (:func:`puppet.geom.mvc.mean_value_coordinates`). Interior pins
   must land on a mask pixel: one that misses by at most :data:`NUDGE` px is moved onto
   the nearest mask pixel's centre, otherwise :class:`NoMatch`;
5. moves each pose target by the template's displacement of that pin turned and scaled
   by the similarity (``angle`` and ``depth`` kept), so a pose means the same on the
   new garment;
6. a caged layer (``layers[i].cage``): carries its cage vertex by vertex (each keeps its
   mean value coordinates relative to the outline) and writes it as ``points``, so that
   handle ``LAYER:cageK`` of the template is ``LAYER:cageK`` of the picture and its pose
   targets move as pins' do; vertices whose edges cut the picture's mesh are pushed out
   (:func:`puppet.batch.cages.enclose`), and a cage that then crosses itself or still
   cannot hold the mesh is a :class:`NoMatch` naming the cage. Its pins are landmarks,
   carried as pins.

Rendering the result (the dict is a scene in memory, every path absolute)::

    from puppet.api import Scene
    scene = Scene(doc, file=os.path.join(out_dir, "shirt-42.json"))  # file: for messages / save
    rgba = scene.render(pose="lift", size=(256, 256))  # (H, W, 4) uint8
    scene.close()                                       # releases its GL context
    # or: scene.save(path) writes it as a scene file with relative paths

Template processing (loading, segmenting, outline) is cached per process by file
content stamp, so calling :func:`transfer` for thousands of pictures with one template
does it once.
"""
from __future__ import annotations

import copy
import functools
import os
from dataclasses import dataclass, field, replace

import numpy as np

from puppet.batch.cages import CageRefused, enclose, nearest_on_ring
from puppet.errors import SceneError
from puppet.geom.contour import mask_regions, ring_area
from puppet.geom.mvc import mean_value_coordinates
from puppet.geom.outline_corr import Correspondence, LandmarkRing, match_outlines
from puppet.geom.outline_match import Similarity
from puppet.imaging.io import load_rgba
from puppet.scene.format.load import load_scene_data, parse_scene
from puppet.scene.format.model import Cage, Layer, SceneData
from puppet.scene.format.physics import raw_chains
from puppet.scene.rig import build
from puppet.scene.rig.cages import cage_handles, rest_cage
from puppet.scene.rig.exterior import auto_points

__all__ = ["NoMatch", "Template", "Transfer", "cached", "transfer", "transfer_points", "NUDGE", "BOUNDARY", "TOLERANCE"]

#: An interior pin that lands off the new mask by at most this many pixels is moved in.
NUDGE = 3.0
#: Pins closer than this to the template outline (px) are carried along the outline.
BOUNDARY = 1.5
#: Default largest match score (:attr:`Transfer.score`).
TOLERANCE = 0.08


class NoMatch(SceneError):
    """The picture's outline does not match the template's within the tolerance (or a pin
    cannot be placed inside the picture's mask)."""


@dataclass
class Transfer:
    """The result of :meth:`Template.transfer`: the scene and how it was obtained."""

    scene: dict
    score: float  # symmetric mean outline distance under the correspondence / sqrt(area)
    distance: float  # the same with nearest points instead (smaller; for information)
    similarity: Similarity  # template canvas -> picture pixels
    landmarks: int  # matched curvature landmarks
    nudged: list[str]  # interior pins moved onto the mask
    grown: list[str] = field(default_factory=list)  # cage handles pushed out to hold the picture's mesh
    picture: np.ndarray | None = field(default=None, repr=False)  # the picture's (h, w, 4) pixels, as read
    mask: np.ndarray | None = field(default=None, repr=False)  # its garment's (h, w) mask, as the scene builds it


def _outline(mask: np.ndarray, offset) -> np.ndarray:
    regions = mask_regions(mask, offset, grow=0)
    regions = [r for r in regions if len(r.outer) >= 8]
    if not regions:
        return np.zeros((0, 2))
    return max(regions, key=lambda r: abs(ring_area(r.outer))).outer


def _inside(poly: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test, (k,) bool."""
    A, B = poly, np.roll(poly, -1, axis=0)
    x, y = X[:, 0:1], X[:, 1:2]
    crosses = (A[None, :, 1] > y) != (B[None, :, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = A[None, :, 0] + (y - A[None, :, 1]) * (B[None, :, 0] - A[None, :, 0]) / (B[None, :, 1] - A[None, :, 1])
    return ((crosses & (x < xi)).sum(axis=1) % 2) == 1


def _project(R: np.ndarray, X: np.ndarray):
    """Nearest point of the closed polyline ``R`` to each of ``X``: its arc length, the
    point, the unit tangent there and the distance."""
    i, t, F, d, E, le2 = nearest_on_ring(R, X)
    s0 = np.r_[0.0, np.cumsum(np.sqrt(le2))[:-1]]
    tan = E[i] / np.sqrt(le2[i])[:, None]
    return s0[i] + t * np.sqrt(le2[i]), F, tan, d


def transfer_points(X, corr: Correspondence, S: Similarity, *, boundary: float = BOUNDARY) -> np.ndarray:
    """Carry points from the template outline's frame to the picture's.

    Parameters
    ----------
    X : (k, 2) float, template coordinates.
    corr : outline correspondence, template -> picture. S : the aligning similarity.

    Returns
    -------
    (k, 2) float, picture coordinates.
    """
    X = np.asarray(X, float).reshape(-1, 2)
    out = np.empty_like(X)
    if not len(X):
        return out
    s, F, tan, d = _project(corr.P, X)
    nrm = np.stack([tan[:, 1], -tan[:, 0]], axis=1)
    on_edge = (d <= boundary) | ~_inside(corr.P, X)
    if on_edge.any():
        R = (X - F)[on_edge]  # offset from the outline, in the local (tangent, normal) frame
        ot, on = (R * tan[on_edge]).sum(axis=1), (R * nrm[on_edge]).sum(axis=1)
        t = corr.map_arclength(s[on_edge])
        tq = corr.q.tangent(t)
        nq = np.stack([tq[:, 1], -tq[:, 0]], axis=1)
        out[on_edge] = corr.q.at(t) + S.scale * (ot[:, None] * tq + on[:, None] * nq)
    if (~on_edge).any():
        L = mean_value_coordinates(corr.P, X[~on_edge])
        out[~on_edge] = L @ corr.corresponding_ring()
    return out


def _carry_cage(X: np.ndarray, corr: Correspondence, S: Similarity) -> np.ndarray:
    """Carry cage vertices (outside the template's outline) to the picture: each keeps its
    mean value coordinates relative to the outline (Hormann-Floater's, defined outside the
    polygon too; exact for affine maps of the outline), applied to the corresponding
    outline. On similarity copies of the t-shirt this lands a 12-vertex cage within 0.6 px
    of the similarity's image, where the exterior pins' rule (:func:`transfer_points`: the
    corresponding outline point plus the scaled offset in its tangent frame) is 0.3-4 px
    off at corners; on the re-proportioned t-shirt 0.7-7 px from the true warp against 2.5-31.
    Falls back to that rule where the coordinates are not finite."""
    Y = mean_value_coordinates(corr.P, X) @ corr.corresponding_ring()
    bad = ~np.isfinite(Y).all(axis=1)
    if bad.any():
        Y[bad] = transfer_points(X[bad], corr, S)
    return Y


def _cage_json(raw: dict, cage: Cage, C: np.ndarray, scale: float) -> dict:
    """The picture's ``layers[0].cage``: the carried points ``C`` (so handle K stays vertex
    K), the template's ``coordinates`` where it names them, and for an automatic cage its
    ``auto`` and its ``offset`` scaled by the similarity (how the points were made)."""
    out = {}
    if cage.auto is not None:
        out = {"auto": cage.auto, "offset": min(round(cage.offset * scale, 1), 1000.0)}  # the format's most
    out["points"] = [[round(float(x), 3), round(float(y), 3)] for x, y in C]
    if "coordinates" in raw:
        out["coordinates"] = cage.coordinates
    return out


def _layer_json(raw: dict, L: Layer, image: str) -> dict:
    """The template layer's settings over the new picture (no offset, own image)."""
    out = {"name": L.name, "image": image}
    mask = raw.get("mask")
    if mask == "alpha" or (isinstance(mask, dict) and "threshold" in mask):
        out["mask"] = copy.deepcopy(mask)
    for key in ("mesh", "exterior"):
        if key in raw:
            out[key] = copy.deepcopy(raw[key])
    return out


class Template:
    """A template garment: the scene, its chosen layer, its mask outline and pins.

    ``Template(path, layer)`` reads and segments the template once (raises SceneError);
    then :meth:`transfer` each picture. :func:`transfer` keeps a few per process.
    """

    def __init__(self, path: str, layer: str | None = None):
        self.path = os.path.abspath(path)
        data = load_scene_data(self.path)
        self.raw = data.raw  # the JSON as written (relative paths; only path-free keys are copied)
        self.data: SceneData = data
        self.layer = self._pick(data, layer)
        source = build.load_source(data) if self.layer.image is None else None
        self.image = build.layer_image(data, self.layer, source)
        self.outline = _outline(self.image.mask, self.image.offset)
        self.ring = LandmarkRing.of(self.outline) if len(self.outline) >= 8 else None
        self.pins = [p for p in data.pins if p.layer == self.layer.name]
        self.auto_ext = None
        if self.layer.exterior is not None:
            self.auto_ext = auto_points(self.image.mask, self.image.offset, self.layer.exterior.beta)
        # the rest cage (given, or made from the template's mask as the scene build makes it)
        self.cage = None if self.layer.cage is None else rest_cage(data, self.layer.index, self.image)

    def _pick(self, data: SceneData, layer: str | None) -> Layer:
        if layer is None:
            if len(data.layers) != 1:
                names = ", ".join(repr(L.name) for L in data.layers)
                raise SceneError(f"the template has {len(data.layers)} layers ({names}): name the garment layer",
                                 file=self.path, path="layers")
            return data.layers[0]
        for L in data.layers:
            if L.name == layer:
                return L
        raise SceneError(f"no layer named {layer!r} in the template", file=self.path, path="layers")

    def transfer(self, image: str, *, tolerance: float = TOLERANCE) -> Transfer:
        """Match ``image`` against the template; see the module doc. Raises NoMatch,
        SceneError (e.g. an unreadable picture: :class:`puppet.errors.ImageError`)."""
        image = os.path.abspath(image)
        rgba = load_rgba(image)
        h, w = rgba.shape[:2]
        raw_layer = self.raw["layers"][self.layer.index]
        doc = {"puppet": 1, "canvas": [w, h], "layers": [_layer_json(raw_layer, self.layer, image)]}
        bg = self.raw.get("background")
        if isinstance(bg, list):
            doc["background"] = list(bg)
        scene_file = os.path.splitext(image)[0] + ".json"
        data = parse_scene(doc, scene_file)
        new = build.layer_image(data, replace(data.layers[0], image=None), rgba)
        Q = _outline(new.mask, (0.0, 0.0))
        if len(Q) < 8 or self.ring is None:
            raise NoMatch(f"the picture's mask has no outline to match against template {self.path!r}", file=image)
        match = match_outlines(self.ring, Q)
        S, score, corr = match.similarity, match.score, match.correspondence
        if not score <= tolerance:
            raise NoMatch(f"outline does not match template {os.path.basename(self.path)!r} layer "
                          f"{self.layer.name!r}: distance {score:.3f} of the garment's size > tolerance "
                          f"{tolerance:.3f} (by {score - tolerance:.3f})", file=image)
        pins, moved, nudged = self._pins(corr, S, new.mask, image, score)
        doc["pins"] = pins
        handles, grown = self._cage(doc, scene_file, corr, S, new) if self.cage is not None else ({}, [])
        self._poses(doc, corr, S, moved, new.mask, handles)
        return Transfer(scene=doc, score=float(score), distance=match.distance, similarity=S,
                        landmarks=len(corr.anchors), nudged=nudged, grown=grown, picture=rgba, mask=new.mask)

    def _pins(self, corr, S, mask: np.ndarray, image: str, score: float):
        X = np.array([p.at for p in self.pins], float).reshape(-1, 2)
        Y = transfer_points(X, corr, S)
        out, moved, nudged = [], {}, []
        raw_pins = {p["name"]: p for p in self.raw.get("pins", [])}
        for p, y in zip(self.pins, Y):
            if p.kind != "exterior":
                y, far = on_mask(mask, y)
                if far > 0:
                    if far > NUDGE:
                        how = f"{far:.1f} px" if np.isfinite(far) else f"more than {NUDGE + 2:g} px"
                        raise NoMatch(f"pin {p.name!r} lands {how} outside the picture's mask (at most "
                                      f"{NUDGE:g} px is nudged in; outline match {score:.3f})", file=image)
                    nudged.append(p.name)
            q = dict(raw_pins[p.name])
            q["at"] = [round(float(y[0]), 3), round(float(y[1]), 3)]
            out.append(q)
            moved[p.name] = (p.at, y)
        return out, moved, nudged

    def _cage(self, doc: dict, scene_file: str, corr, S: Similarity, new):
        """Carry the template's cage to the picture (``doc``'s layer gets it as ``points``,
        an automatic cage keeping ``auto`` and its offset scaled): each vertex keeps its
        mean value coordinates relative to the outline (:func:`_carry_cage`), then the vertices whose edges cut
        the picture's mesh are pushed out (:func:`puppet.batch.cages.enclose`). Returns
        {handle: (template vertex, picture vertex)} and the names of the pushed handles;
        raises NoMatch naming the cage where it crosses itself or cannot hold the mesh."""
        k = self.layer.index
        data = parse_scene(doc, scene_file)  # the layer and its pins, no cage yet
        V = build.mesh_layer(data, 0, new, build.layer_areas(data, [new])[0], []).V  # as the build meshes it
        Y = np.round(_carry_cage(self.cage, corr, S), 3)
        try:
            C, pushed = enclose(Y, V, reach=0.1 * np.sqrt(new.mask.sum()))
        except CageRefused as e:
            raise NoMatch(f"the cage of template {os.path.basename(self.path)!r} layer {self.layer.name!r} "
                          f"(layers[{k}].cage), carried to the picture, {e}",
                          file=doc["layers"][0]["image"]) from None
        out = doc["layers"][0]["cage"] = _cage_json(self.raw["layers"][k]["cage"], self.layer.cage, C, S.scale)
        names = cage_handles(self.layer.name, self.cage)
        handles = {nm: (at, np.array(q)) for nm, at, q in zip(names, self.cage, out["points"])}
        return handles, [names[j] for j in pushed]

    def _ext_map(self, corr, S, mask: np.ndarray) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
        """Template automatic exterior point name -> (the new picture's point it became,
        its template position, its new position). Matched one-to-one by the transferred
        positions; a point with no counterpart within a tenth of the garment's size is left out."""
        if self.auto_ext is None or not len(self.auto_ext):
            return {}
        from scipy.optimize import linear_sum_assignment

        new = auto_points(mask, (0.0, 0.0), self.layer.exterior.beta)
        if not len(new):
            return {}
        Y = transfer_points(self.auto_ext, corr, S)
        D = np.linalg.norm(Y[:, None] - new[None], axis=2)
        r, c = linear_sum_assignment(D)
        gate = 0.1 * np.sqrt(mask.sum())
        name = self.layer.name
        return {f"{name}:ext{i}": (f"{name}:ext{j}", self.auto_ext[i], new[j])
                for i, j in zip(r, c) if D[i, j] <= gate}

    def _poses(self, doc: dict, corr, S: Similarity, moved: dict, mask: np.ndarray, handles: dict) -> None:
        ext = self._ext_map(corr, S, mask) if self.auto_ext is not None else {}
        ext.update((nm, (nm, at, y)) for nm, (at, y) in handles.items())  # cage handles keep their names

        def pose(p: dict) -> dict:
            out = {}
            for nm, t in p.items():
                if nm in moved:
                    new_name, (at, y) = nm, moved[nm]
                elif nm in ext:
                    new_name, at, y = ext[nm]
                else:
                    continue  # a pin of another layer, or an exterior point with no counterpart
                if t is None:  # a key's override leaving the pin out
                    out[new_name] = None
                elif isinstance(t, list):
                    out[new_name] = _target(y, S, np.asarray(t, float) - at)
                else:
                    t = dict(t)
                    if "to" in t:
                        t["to"] = _target(y, S, np.asarray(t["to"], float) - at)
                    out[new_name] = t
            return out

        if "deformer" in self.raw:
            doc["deformer"] = copy.deepcopy(self.raw["deformer"])
        bones = [b for b in self.raw.get("bones", []) if b[0] in moved and b[1] in moved]
        if bones:
            doc["bones"] = bones
        doc["poses"] = {k: pose(v) for k, v in self.raw.get("poses", {}).items()}
        if "animation" in self.raw:
            anim = copy.deepcopy(self.raw["animation"])
            for key in anim.get("keys", []):
                for f in ("pins", "overrides"):  # a key of inline pin targets, a pose key's overrides
                    if isinstance(key.get(f), dict):
                        key[f] = pose(key[f])
            doc["animation"] = anim
        chains = [ch for ch in raw_chains(self.raw) if all(nm in moved for nm in ch["pins"])]
        if chains:  # secondary motion of the garment's own pins
            doc["physics"] = {"chains": copy.deepcopy(chains)}


def _target(y: np.ndarray, S: Similarity, d: np.ndarray) -> list[float]:
    q = y + S.apply_vector(d)
    return [round(float(q[0]), 3), round(float(q[1]), 3)]


def on_mask(mask: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """``y`` if its pixel is a mask pixel (distance 0), else the centre of the nearest
    mask pixel and how far that is."""
    h, w = mask.shape
    j, i = int(np.floor(y[0])), int(np.floor(y[1]))
    if 0 <= i < h and 0 <= j < w and mask[i, j]:
        return y, 0.0
    r = int(np.ceil(NUDGE)) + 2
    i0, i1, j0, j1 = max(i - r, 0), min(i + r + 1, h), max(j - r, 0), min(j + r + 1, w)
    ii, jj = np.nonzero(mask[i0:i1, j0:j1]) if i0 < i1 and j0 < j1 else (np.zeros(0, int), np.zeros(0, int))
    if not len(ii):
        return y, float("inf")
    C = np.stack([jj + j0 + 0.5, ii + i0 + 0.5], axis=1)
    d = np.linalg.norm(C - y, axis=1)
    k = int(d.argmin())
    return C[k], float(d[k])


@functools.lru_cache(maxsize=8)
def _cached(path: str, layer: str | None, stamp: tuple) -> Template:
    return Template(path, layer)


def _stamp(path: str) -> tuple:
    st = os.stat(path)
    return (st.st_mtime_ns, st.st_size, st.st_ino)


def transfer(template: str, image: str, *, tolerance: float | None = TOLERANCE, layer: str | None = None) -> dict:
    """A scene for the garment picture ``image`` with ``template``'s pins and poses.

    Parameters
    ----------
    template : path of a scene file whose one layer (or ``layer``) is a garment.
    image : path of a garment picture.
    tolerance : largest match score (symmetric mean outline distance / sqrt(area));
        None means :data:`TOLERANCE`.
    layer : the template's garment layer, when it has several.

    Returns
    -------
    dict : the scene JSON (every path absolute; canvas = the picture's size), ready for
    ``puppet.api.Scene(doc, file=...)`` (see the module doc).

    Raises
    ------
    NoMatch : the outlines differ by more than ``tolerance``, or a pin cannot be placed.
    SceneError : a bad template or an unreadable picture.
    """
    tpl = cached(template, layer)
    return tpl.transfer(image, tolerance=TOLERANCE if tolerance is None else tolerance).scene


def cached(template: str, layer: str | None = None) -> Template:
    """The :class:`Template` of ``template`` (read once per process while its file is unchanged)."""
    path = os.path.abspath(template)
    try:
        stamp = _stamp(path)
    except OSError:
        stamp = ()
    return _cached(path, layer, stamp) if stamp else Template(path, layer)
