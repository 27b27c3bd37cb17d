"""Read a scene file (format v1) into a validated :class:`SceneData`.

This checks everything that can be checked from the JSON alone; checks that need
pixels (pins inside masks, links inside both masks) are made when the layers are built.
"""
from __future__ import annotations

import os
import re

import numpy as np

from puppet.imaging import masks as mk
from puppet.imaging.io import MAX_SIDE
from puppet.scene.format import model as m
from puppet.scene.format.animation import parse_animation
from puppet.scene.format.extensions import parse_app
from puppet.scene.format.garment import parse_garment
from puppet.scene.format.reader import parse_text, read_text
from puppet.scene.format.schema import (
    Ctx,
    expect_bool,
    expect_list,
    expect_number,
    expect_object,
    expect_point,
    expect_string,
    join,
    short,
)
from puppet.scene.format.physics import parse_physics
from puppet.scene.format.video import parse_video

TOP_KEYS = ("puppet", "canvas", "background", "source", "layers", "links", "pins", "bones",
            "deformer", "poses", "animation", "app", "video", "physics", "garment")
MAX_CANVAS = 16384
#: Most points a polygon mask may have.
MAX_POLYGON_POINTS = 100_000
EXTERIOR_NAME = re.compile(r"^(?P<layer>.+):ext(?P<i>\d+)$")
#: A cage vertex as a handle of poses and keys: ``LAYER:cageN`` (N in the cage's point order).
CAGE_NAME = re.compile(r"^(?P<layer>.+):cage(?P<i>\d+)$")
#: Most vertices a cage may have (given or automatic).
MAX_CAGE_POINTS = 1000


def read_json(path: str):
    """Parse a scene file strictly (see :mod:`puppet.scene.format.reader`); every failure
    becomes a SceneError naming the file and, where there is one, the JSON path."""
    return parse_text(read_text(path), path)


def load_scene_data(path: str) -> m.SceneData:
    """Read and validate a scene file. Raises SceneError."""
    path = os.path.abspath(path)
    raw = read_json(path)
    return parse_scene(raw, path)


def parse_scene(raw, file: str) -> m.SceneData:
    c = Ctx(file)
    folder = os.path.dirname(file)
    expect_object(c, raw, "", required=("puppet", "layers"), optional=TOP_KEYS)
    if isinstance(raw["puppet"], bool) or raw["puppet"] != 1:
        raise c.fail("puppet", f"unsupported format version {short(raw['puppet'])} (this puppet reads version 1)")

    def file_path(v, p):
        name = expect_string(c, v, p)
        if "\0" in name:
            raise c.fail(p, "a file path cannot hold a NUL byte")
        return os.path.normpath(os.path.join(folder, name))

    canvas = None
    if "canvas" in raw:
        expect_list(c, raw["canvas"], "canvas", length=2)
        canvas = tuple(expect_number(c, raw["canvas"][i], f"canvas[{i}]", lo=1, hi=MAX_CANVAS, integer=True)
                       for i in range(2))
    background = (0, 0, 0, 0)
    if "background" in raw:
        bg = raw["background"]
        if isinstance(bg, str):
            background = file_path(bg, "background")
        else:
            expect_list(c, bg, "background", length=4)
            background = tuple(expect_number(c, x, f"background[{i}]", lo=0, hi=255, integer=True)
                               for i, x in enumerate(bg))
    source = file_path(raw["source"], "source") if "source" in raw else None
    video = parse_video(c, raw, source, canvas)  # a video scene (compatible extension): probed now
    if video is not None:
        canvas = video["size"]

    layers = [_layer(c, v, f"layers[{i}]", i, file_path, source)
              for i, v in enumerate(expect_list(c, raw["layers"], "layers", min_len=1))]
    names = {}
    for L in layers:
        if L.name in names:
            raise c.fail(f"layers[{L.index}].name", f"duplicate layer name {short(L.name)} (also layers[{names[L.name]}])")
        names[L.name] = L.index

    links = [_link(c, v, f"links[{i}]", names) for i, v in enumerate(expect_list(c, raw.get("links", []), "links"))]
    for i, k in enumerate(links):
        for j, nm in enumerate(k.layers):
            if layers[names[nm]].cage is not None:
                raise c.fail(f"links[{i}].layers[{j}]", f"layer {short(nm)} has a cage (a caged layer is deformed by "
                                                        "its cage alone and takes no part in a linked group)")
    pins = [_pin(c, v, f"pins[{i}]", names) for i, v in enumerate(expect_list(c, raw.get("pins", []), "pins"))]
    pin_names: dict[str, int] = {}
    for i, p in enumerate(pins):
        if p.name in pin_names:
            raise c.fail(f"pins[{i}].name", f"duplicate pin name {short(p.name)} (also pins[{pin_names[p.name]}])")
        pin_names[p.name] = i
        mt = EXTERIOR_NAME.match(p.name)
        if mt and mt.group("layer") in names and layers[names[mt.group("layer")]].exterior:
            raise c.fail(f"pins[{i}].name", f"{short(p.name)} is reserved for the layer's automatic exterior points")
        if _cage_of(p.name, layers, names) is not None:
            raise c.fail(f"pins[{i}].name", f"{short(p.name)} is reserved for the layer's cage vertices")
        if p.kind == "exterior" and layers[names[p.layer]].cage is not None:
            raise c.fail(f"pins[{i}].kind", f"layer {short(p.layer)} has a cage: its cage vertices are its exterior "
                                            "handles (LAYER:cageN), it takes no exterior pins")

    bones = []
    for i, b in enumerate(expect_list(c, raw.get("bones", []), "bones")):
        p = f"bones[{i}]"
        expect_list(c, b, p, length=2)
        a, z = (expect_string(c, b[k], join(p, k)) for k in range(2))
        for k, nm in enumerate((a, z)):
            if nm not in pin_names:
                raise c.fail(join(p, k), f"no pin named {short(nm)}")
        if a == z:
            raise c.fail(p, "a bone joins two different pins")
        bones.append((a, z))

    deformer = _deformer(c, raw.get("deformer", {}), "deformer")
    starch = frozenset(p.name for p in pins if p.kind == "starch")
    _check_modes(c, deformer, layers)
    poses = {}
    pv = expect_object(c, raw.get("poses", {}), "poses", optional=raw.get("poses", {}).keys()
                       if isinstance(raw.get("poses", {}), dict) else ())
    for name, pose in pv.items():
        p = join("poses", name)
        if name == "rest":
            raise c.fail(p, "the pose name 'rest' is reserved (every pin at its 'at')")
        if not name.strip():
            raise c.fail(p, "a pose needs a non-empty name")
        poses[name] = _pose(c, pose, p, pin_names, layers, names, starch)

    animation = None
    if "animation" in raw:
        animation = parse_animation(c, raw["animation"], "animation", poses,
                                    lambda v, q: _pose(c, v, q, pin_names, layers, names, starch))
    if "app" in raw:  # app-only settings (a compatible extension; render ignores them)
        parse_app(c, raw["app"], "app", file_path)
    chains = parse_physics(c, raw["physics"], "physics", pins) if "physics" in raw else []
    garment = parse_garment(c, raw["garment"], "garment") if "garment" in raw else None  # puppet dressroom's
    return m.SceneData(file=file, canvas=canvas, background=background, source=source, layers=layers,
                       links=links, pins=pins, bones=bones, deformer=deformer, poses=poses,
                       animation=animation, raw=raw, video=video, chains=chains, garment=garment)


def _layer(c, v, p, index, file_path, source) -> m.Layer:
    expect_object(c, v, p, required=("name",),
                  optional=("name", "image", "offset", "mask", "order", "inpaint", "mesh", "exterior",
                            "deformer", "stiffness", "visible", "cage"))
    name = expect_string(c, v["name"], join(p, "name"))
    image = file_path(v["image"], join(p, "image")) if "image" in v else None
    if image is None and source is None:
        raise c.fail(join(p, "image"), f"layer {short(name)} has no image and the scene has no 'source' to take pixels from")
    offset = expect_point(c, v["offset"], join(p, "offset")) if "offset" in v else (0.0, 0.0)
    mask = _mask(c, v["mask"], join(p, "mask"), file_path, offset) if "mask" in v else None
    order = expect_number(c, v["order"], join(p, "order")) if "order" in v else None
    inpaint = expect_string(c, v.get("inpaint", "none"), join(p, "inpaint"), choices=m.INPAINT_METHODS)
    mesh = m.MeshOptions()
    if "mesh" in v:
        mp = join(p, "mesh")
        mo = expect_object(c, v["mesh"], mp, optional=("max_area", "min_angle", "simplify"))
        if "max_area" in mo:
            mesh.max_area = expect_number(c, mo["max_area"], join(mp, "max_area"), lo=0.5, hi=1e7)
        if "min_angle" in mo:
            mesh.min_angle = expect_number(c, mo["min_angle"], join(mp, "min_angle"), lo=0, hi=34, lo_open=True)
        if "simplify" in mo:
            mesh.simplify = expect_number(c, mo["simplify"], join(mp, "simplify"), lo=0, hi=1000)
    exterior = None
    if "exterior" in v:
        ep = join(p, "exterior")
        eo = expect_object(c, v["exterior"], ep, optional=("auto", "beta"))
        auto = expect_bool(c, eo.get("auto", True), join(ep, "auto"))
        beta = expect_number(c, eo.get("beta", 1.0), join(ep, "beta"), lo=0, lo_open=True, hi=1000)
        exterior = m.Exterior(auto=auto, beta=beta) if auto else None
    mode = None
    if "deformer" in v:  # a layer overrides the scene's mode (its cells' energy)
        dp = join(p, "deformer")
        do = expect_object(c, v["deformer"], dp, optional=("mode",))
        mode = expect_string(c, do["mode"], join(dp, "mode"), choices=m.MODES) if "mode" in do else None
    stiffness = None
    if "stiffness" in v:
        sp_ = join(p, "stiffness")
        so = expect_object(c, v["stiffness"], sp_, required=("file",))
        stiffness = file_path(so["file"], join(sp_, "file"))
    visible = expect_bool(c, v.get("visible", True), join(p, "visible"))
    cage = _cage(c, v["cage"], join(p, "cage")) if "cage" in v else None
    if cage is not None and exterior is not None:
        raise c.fail(join(p, "exterior"), "a caged layer has no automatic exterior points (its cage shapes its "
                                          "outline): remove 'exterior' or the cage")
    return m.Layer(name=name, image=image, offset=offset, mask=mask, order=order, inpaint=inpaint,
                   mesh=mesh, exterior=exterior, index=index, mode=mode, stiffness=stiffness, visible=visible,
                   cage=cage)


def _cage(c, v, p) -> m.Cage:
    """``layers[i].cage``: ``{"points": [...]}`` or ``{"auto": N, "offset": PX}`` (a saved
    automatic cage has both: its points are used), and ``coordinates``."""
    from puppet.deform.cage import check_cage  # lazy: it loads scipy, which a scene without a cage never needs

    expect_object(c, v, p, optional=("points", "auto", "offset", "coordinates"))
    if "points" not in v and "auto" not in v:
        raise c.fail(join(p, "points"), "required key is missing (a cage needs 'points' or 'auto')")
    kind = expect_string(c, v.get("coordinates", m.CAGE_KINDS[0]), join(p, "coordinates"), choices=m.CAGE_KINDS)
    auto = expect_number(c, v["auto"], join(p, "auto"), lo=3, hi=MAX_CAGE_POINTS, integer=True) if "auto" in v else None
    if "offset" in v and auto is None:
        raise c.fail(join(p, "offset"), "an offset belongs to an automatic cage ('auto': N)")
    offset = expect_number(c, v.get("offset", 10.0), join(p, "offset"), lo=0, hi=1000)
    points = None
    if "points" in v:
        pp = join(p, "points")
        P = np.array([expect_point(c, q, join(pp, i)) for i, q in enumerate(expect_list(
            c, v["points"], pp, max_len=MAX_CAGE_POINTS))], np.float64).reshape(-1, 2)
        msg = check_cage(P)
        if msg:
            raise c.fail(pp, f"the cage {msg}")
        points = P
    return m.Cage(points=points, auto=auto, offset=offset, coordinates=kind)


def _cage_of(name: str, layers, names) -> m.Cage | None:
    """The cage a handle name ``LAYER:cageN`` belongs to, None if it names none."""
    mt = CAGE_NAME.match(name)
    if mt and mt.group("layer") in names:
        return layers[names[mt.group("layer")]].cage
    return None


def _mask(c, v, p, file_path, offset=(0.0, 0.0)) -> m.Mask:
    if isinstance(v, str):
        if v != "alpha":
            raise c.fail(p, f"{short(v)} is not a mask; use \"alpha\" or an object with one of: "
                            "threshold, polygon, rect, file, grabcut")
        return m.Mask("alpha")
    if not isinstance(v, dict) or not v:
        raise c.fail(p, "expected \"alpha\" or an object with one of: threshold, polygon, rect, file, grabcut")
    kinds = [k for k in ("threshold", "polygon", "rect", "file", "grabcut") if k in v]
    if len(kinds) != 1:
        if not kinds:
            expect_object(c, v, p, optional=("threshold", "invert", "polygon", "rect", "file", "grabcut"))
        raise c.fail(p, f"a mask has exactly one of threshold, polygon, rect, file, grabcut (got {', '.join(kinds)})")
    kind = kinds[0]
    expect_object(c, v, p, required=(kind,), optional=(kind, "invert") if kind == "threshold" else (kind,))
    kp = join(p, kind)
    if kind == "threshold":
        return m.Mask("threshold", threshold=expect_number(c, v[kind], kp, lo=0, hi=256),
                      invert=expect_bool(c, v.get("invert", False), join(p, "invert")))
    if kind == "polygon":
        pts = expect_list(c, v[kind], kp, min_len=3, max_len=MAX_POLYGON_POINTS)
        P = np.array([expect_point(c, q, join(kp, i)) for i, q in enumerate(pts)])
        # filled by the even-odd rule, so it may cross itself; only a flat one is refused
        spread = np.linalg.svd(P - P.mean(axis=0), compute_uv=False)
        if spread[1] <= 1e-9 * max(spread[0], 1.0):
            raise c.fail(kp, "polygon encloses no area (its points lie on one line)")
        n = mk.polygon_crossings(P, offset, MAX_SIDE)
        if n > mk.MAX_CROSSINGS:
            raise c.fail(kp, f"polygon too intricate to fill: its edges cross {n:,} pixel rows "
                             f"(at most {mk.MAX_CROSSINGS:,})")
        return m.Mask("polygon", polygon=P)
    if kind in ("rect", "grabcut"):
        expect_list(c, v[kind], kp, length=4)
        r = tuple(expect_number(c, x, join(kp, i)) for i, x in enumerate(v[kind]))
        if r[2] <= 0 or r[3] <= 0:
            raise c.fail(kp, f"width and height must be positive, got {r[2]:g} x {r[3]:g}")
        return m.Mask(kind, rect=r)
    return m.Mask("file", file=file_path(v[kind], kp))


def _link(c, v, p, names) -> m.Link:
    expect_object(c, v, p, required=("layers",), optional=("layers", "segments", "points", "polygons", "strength"))
    if not any(k in v for k in ("segments", "points", "polygons")):
        raise c.fail(join(p, "segments"), "required key is missing (a link needs at least one of segments, points, polygons)")
    lp = join(p, "layers")
    expect_list(c, v["layers"], lp, length=2)
    a, b = (expect_string(c, v["layers"][k], join(lp, k)) for k in range(2))
    for k, nm in enumerate((a, b)):
        if nm not in names:
            raise c.fail(join(lp, k), f"no layer named {short(nm)}")
    if a == b:
        raise c.fail(lp, "a link joins two different layers")
    sp = join(p, "segments")
    segs = []
    for i, s in enumerate(expect_list(c, v["segments"], sp, min_len=1) if "segments" in v else []):
        q = join(sp, i)
        expect_list(c, s, q, length=2)
        S = np.array([expect_point(c, s[k], join(q, k)) for k in range(2)])
        if np.linalg.norm(S[1] - S[0]) < 1e-6:
            raise c.fail(q, "segment has zero length")
        segs.append(S)
    pp = join(p, "points")
    points = [np.array(expect_point(c, q, join(pp, i)))
              for i, q in enumerate(expect_list(c, v["points"], pp, min_len=1, max_len=1000) if "points" in v else [])]
    gp = join(p, "polygons")
    polys = []
    for i, q in enumerate(expect_list(c, v["polygons"], gp, min_len=1, max_len=100) if "polygons" in v else []):
        qp = join(gp, i)
        P = np.array([expect_point(c, x, join(qp, j)) for j, x in enumerate(expect_list(c, q, qp, min_len=3,
                                                                                          max_len=1000))])
        if abs(_ring_area(P)) < 1e-6:
            raise c.fail(qp, "polygon encloses no area")
        polys.append(P)
    strength = expect_number(c, v.get("strength", 1.0), join(p, "strength"), lo=0, hi=1)
    return m.Link(layers=(a, b), segments=segs, points=points, polygons=polys, strength=strength)


def _check_modes(c, d: m.Deformer, layers) -> None:
    """Modes other than rigid are ARAP cell energies: other methods refuse them. Anderson
    acceleration is for rigid ARAP only."""
    if d.accelerate != "none":
        if d.method != "arap":
            raise c.fail("deformer.accelerate", f"{d.accelerate!r} needs method 'arap' (the method is {d.method!r})")
        bent = [("deformer.mode", d.mode)] + [(f"layers[{L.index}].deformer.mode", L.mode) for L in layers]
        for path, mode in bent:
            if mode not in (None, "rigid"):
                raise c.fail(path, f"mode {mode!r} cannot be accelerated (deformer.accelerate {d.accelerate!r} "
                                   "needs rigid cells)")
    if d.method == "arap":
        return
    if d.mode != "rigid":
        raise c.fail("deformer.mode", f"mode {d.mode!r} needs method 'arap' (the method is {d.method!r})")
    for L in layers:
        if L.mode not in (None, "rigid"):
            raise c.fail(f"layers[{L.index}].deformer.mode",
                         f"mode {L.mode!r} needs deformer.method 'arap' (the method is {d.method!r})")


def _ring_area(P) -> float:
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _pin(c, v, p, names) -> m.Pin:
    expect_object(c, v, p, required=("name", "layer", "at"),
                  optional=("name", "layer", "at", "depth", "kind", "radius"))
    name = expect_string(c, v["name"], join(p, "name"))
    layer = expect_string(c, v["layer"], join(p, "layer"))
    if layer not in names:
        raise c.fail(join(p, "layer"), f"no layer named {short(layer)}")
    at = np.array(expect_point(c, v["at"], join(p, "at")))
    depth = expect_number(c, v.get("depth", 0.0), join(p, "depth"), lo=-1e4, hi=1e4)
    kind = expect_string(c, v.get("kind", "interior"), join(p, "kind"), choices=m.PIN_KINDS)
    radius = None
    if "radius" in v:
        if kind != "starch":
            raise c.fail(join(p, "radius"), "only a starch pin (\"kind\": \"starch\") has a radius")
        radius = expect_number(c, v["radius"], join(p, "radius"), lo=0, lo_open=True, hi=1e4)
    return m.Pin(name=name, layer=layer, at=at, depth=depth, kind=kind, radius=radius)


def _deformer(c, v, p) -> m.Deformer:
    expect_object(c, v, p, optional=("method", "weights", "init", "iterations", "alpha", "relax_foldovers", "mode",
                                     "accelerate", "tolerance"))
    d = m.Deformer()
    d.method = expect_string(c, v.get("method", d.method), join(p, "method"), choices=m.METHODS)
    d.weights = expect_string(c, v.get("weights", d.weights), join(p, "weights"), choices=m.WEIGHTS)
    d.init = expect_string(c, v.get("init", d.init), join(p, "init"), choices=m.INITS)
    d.iterations = expect_number(c, v.get("iterations", d.iterations), join(p, "iterations"), lo=0, hi=10000,
                                 integer=True)
    d.alpha = expect_number(c, v.get("alpha", d.alpha), join(p, "alpha"), lo=0, lo_open=True, hi=20)
    d.relax_foldovers = expect_bool(c, v.get("relax_foldovers", True), join(p, "relax_foldovers"))
    d.mode = expect_string(c, v.get("mode", d.mode), join(p, "mode"), choices=m.MODES)
    d.accelerate = expect_string(c, v.get("accelerate", d.accelerate), join(p, "accelerate"), choices=m.ACCELERATIONS)
    if d.accelerate != "none" and "iterations" not in v:
        d.iterations = m.ACCELERATED_ITERATIONS
    d.tolerance = expect_number(c, v.get("tolerance", d.tolerance), join(p, "tolerance"), lo=0, lo_open=True, hi=100)
    if "tolerance" in v and d.accelerate == "none":
        raise c.fail(join(p, "tolerance"), 'a tolerance needs "accelerate": "anderson" (plain ARAP runs '
                                           '"iterations" iterations)')
    return d


def _pose(c, v, p, pin_names, layers, names, starch=frozenset()) -> dict[str, m.Target]:
    expect_object(c, v, p, optional=v.keys() if isinstance(v, dict) else ())
    out = {}
    for pin, t in v.items():
        q = join(p, pin)
        mt = EXTERIOR_NAME.match(pin)
        auto_ext = mt and mt.group("layer") in names and layers[names[mt.group("layer")]].exterior
        cage = _cage_of(pin, layers, names)
        if cage is not None and cage.points is not None and int(CAGE_NAME.match(pin).group("i")) >= len(cage.points):
            layer = CAGE_NAME.match(pin).group("layer")
            raise c.fail(q, f"layer {short(layer)} has a cage of {len(cage.points)} points ({layer}:cage0 .. "
                            f"{layer}:cage{len(cage.points) - 1}), so {short(pin)} does not exist")
        if pin not in pin_names and not auto_ext and cage is None:
            raise c.fail(q, f"no pin named {short(pin)}")
        if pin in starch:
            raise c.fail(q, f"{short(pin)} is a starch pin: it stiffens the shape around it and holds no "
                            "position, so a pose cannot move it")
        if isinstance(t, list):
            out[pin] = m.Target(to=np.array(expect_point(c, t, q)))
            continue
        expect_object(c, t, q, optional=("to", "angle", "depth"))
        to = np.array(expect_point(c, t["to"], join(q, "to"))) if "to" in t else None
        angle = expect_number(c, t.get("angle", 0.0), join(q, "angle"), lo=-3600, hi=3600)
        depth = expect_number(c, t["depth"], join(q, "depth"), lo=-1e4, hi=1e4) if "depth" in t else None
        out[pin] = m.Target(to=to, angle=angle, depth=depth)
    return out
