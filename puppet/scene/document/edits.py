"""Every edit of a scene as a method: pins, layers, links, poses, targets (animation keys
are in :mod:`puppet.scene.document.key_edits`).

Each method changes a copy of the scene JSON through ``Document._edit``, which validates
it exactly as a loaded file is validated (so an edit can never make a scene that would
not load), records one undo step and emits one :class:`~puppet.scene.document.history.Event`,
only when something really changed. Paths given to an edit are relative to the current
directory (or absolute).
"""
from __future__ import annotations

import os

import numpy as np

from puppet.errors import SceneError
from puppet.imaging.io import load_rgba
from puppet.scene.document.files import mask_rgba
from puppet.scene.document.history import Event
from puppet.scene.format import args as ck
from puppet.scene.format.extensions import underlay_json
from puppet.scene.format.load import CAGE_NAME, EXTERIOR_NAME
from puppet.scene.format.physics import drop_chain_pins, raw_chains


def _xy(p) -> list[float]:
    return [float(p[0]), float(p[1])]


class Edits:
    """Edit methods of :class:`puppet.scene.document.core.Document` (a mixin)."""

    # helpers ----------------------------------------------------------------------
    def _fail(self, message: str):
        return SceneError(message, file=self.file)

    def _pin(self, doc: dict, name: str) -> dict:
        for p in doc.get("pins", []):
            if p["name"] == name:
                return p
        raise self._fail(f"no pin named {name!r}")

    def _layer(self, doc: dict, name: str) -> dict:
        for L in doc["layers"]:
            if L["name"] == name:
                return L
        raise self._fail(f"no layer named {name!r}")

    def _pose_of(self, doc: dict, pose: str | None) -> tuple[dict, str | None]:
        """The pose table to write (the active pose when None); editing ``rest`` makes a new pose,
        returned as the second item so that it becomes active."""
        name = self._active if pose is None else pose
        if name == "rest":
            poses = doc.setdefault("poses", {})
            k = len(poses) + 1
            while f"pose{k}" in poses:
                k += 1
            name = f"pose{k}"
            poses[name] = {}
            return poses[name], name
        if name not in doc.get("poses", {}):
            raise self._fail(f"no pose named {name!r}")
        return doc["poses"][name], None

    # pins ---------------------------------------------------------------------------
    @ck.checked(name=ck.text, layer=ck.text, at=ck.point, depth=ck.COORD, kind=ck.text)
    def add_pin(self, name: str, layer: str, at, *, depth: float = 0.0, kind: str = "interior") -> bool:
        """A new pin on ``layer`` at canvas point ``at`` (rest position)."""
        def m(doc):
            if any(p["name"] == name for p in doc.get("pins", [])):
                raise self._fail(f"a pin named {name!r} exists already")
            self._layer(doc, layer)
            pin = {"name": name, "layer": layer, "at": _xy(at)}
            if depth:
                pin["depth"] = float(depth)
            if kind != "interior":
                pin["kind"] = kind
            doc.setdefault("pins", []).append(pin)
        return self._edit(Event("pin", name, "precompute", f"add pin {name}"), m)

    @ck.checked(name=ck.text)
    def remove_pin(self, name: str) -> bool:
        """Remove a pin, its targets in every pose, the bones that use it and its place in a
        physics chain (a chain left with one pin goes)."""
        def m(doc):
            self._pin(doc, name)
            doc["pins"] = [p for p in doc["pins"] if p["name"] != name]
            for owner, k in _pin_tables(doc):
                owner[k].pop(name, None)
            if "bones" in doc:
                doc["bones"] = [b for b in doc["bones"] if name not in b]
            drop_chain_pins(doc, lambda x: x == name)
        return self._edit(Event("pin", name, "precompute", f"remove pin {name}"), m)

    @ck.checked(name=ck.text, at=ck.point)
    def move_pin(self, name: str, at) -> bool:
        """Move a pin's rest position (``at``)."""
        def m(doc):
            self._pin(doc, name)["at"] = _xy(at)
        return self._edit(Event("pin", name, "precompute", f"move pin {name}"), m)

    @ck.checked(old=ck.text, new=ck.text)
    def rename_pin(self, old: str, new: str) -> bool:
        """Rename a pin everywhere: pins, poses, bones, physics chains."""
        def m(doc):
            if old != new and any(p["name"] == new for p in doc.get("pins", [])):
                raise self._fail(f"a pin named {new!r} exists already")
            self._pin(doc, old)["name"] = new
            for owner, t in _pin_tables(doc):
                owner[t] = {(new if k == old else k): v for k, v in owner[t].items()}
            if "bones" in doc:
                doc["bones"] = [[new if x == old else x for x in b] for b in doc["bones"]]
            for ch in raw_chains(doc):
                ch["pins"] = [new if x == old else x for x in ch["pins"]]
        return self._edit(Event("pin", new, "none", f"rename pin {old}"), m)

    @ck.checked(name=ck.text, depth=ck.optional(ck.COORD), kind=ck.optional(ck.text))
    def set_pin(self, name: str, *, depth: float | None = None, kind: str | None = None) -> bool:
        """Set a pin's rest depth and/or kind (``interior``, ``exterior`` or ``starch``)."""
        def m(doc):
            p = self._pin(doc, name)
            if depth is not None:
                p["depth"] = float(depth)
            if kind is not None:
                p["kind"] = kind
                if kind != "starch":
                    p.pop("radius", None)  # only a starch pin has a radius
        return self._edit(Event("pin", name, "precompute", f"change pin {name}"), m)

    # layers -------------------------------------------------------------------------
    @ck.checked(name=ck.text, image=ck.optional(ck.path), index=ck.optional(ck.INDEX), fields=ck.plain)
    def add_layer(self, name: str, *, image: str | None = None, index: int | None = None, **fields) -> bool:
        """A new layer (``image`` file or the scene's source; ``fields``: offset, mask,
        order, inpaint, mesh, exterior as in the scene format), in front unless ``index``."""
        def m(doc):
            if any(L["name"] == name for L in doc["layers"]):
                raise self._fail(f"a layer named {name!r} exists already")
            L = {"name": name}
            if image is not None:
                L["image"] = os.path.abspath(image)
            L.update(_layer_fields(fields))
            doc["layers"].insert(len(doc["layers"]) if index is None else index, L)
        return self._edit(Event("layer", name, "mesh", f"add layer {name}"), m)

    @ck.checked(name=ck.text)
    def remove_layer(self, name: str) -> bool:
        """Remove a layer with its pins, its links and their targets in every pose."""
        def m(doc):
            self._layer(doc, name)
            if len(doc["layers"]) == 1:
                raise self._fail("a scene keeps at least one layer")
            doc["layers"] = [L for L in doc["layers"] if L["name"] != name]
            gone = {p["name"] for p in doc.get("pins", []) if p["layer"] == name}
            if "pins" in doc:
                doc["pins"] = [p for p in doc["pins"] if p["layer"] != name]
            if "links" in doc:
                doc["links"] = [k for k in doc["links"] if name not in k["layers"]]
            if "bones" in doc:
                doc["bones"] = [b for b in doc["bones"] if not gone & set(b)]
            drop_chain_pins(doc, gone.__contains__)
            for owner, t in _pin_tables(doc):
                owner[t] = {k: v for k, v in owner[t].items() if k not in gone and _ext_layer(k) != name}
        return self._edit(Event("layer", name, "mesh", f"remove layer {name}"), m)

    @ck.checked(name=ck.text, index=ck.INDEX)
    def reorder_layer(self, name: str, index: int) -> bool:
        """Move a layer to list position ``index`` (the stacking order; later = in front)."""
        def m(doc):
            L = self._layer(doc, name)
            doc["layers"].remove(L)
            doc["layers"].insert(index if index >= 0 else len(doc["layers"]) + 1 + index, L)
        return self._edit(Event("layer", name, "mesh", f"reorder layer {name}"), m)

    @ck.checked(old=ck.text, new=ck.text)
    def rename_layer(self, old: str, new: str) -> bool:
        """Rename a layer everywhere: pins, links, automatic exterior point names in poses."""
        def m(doc):
            if old != new and any(L["name"] == new for L in doc["layers"]):
                raise self._fail(f"a layer named {new!r} exists already")
            self._layer(doc, old)["name"] = new
            for p in doc.get("pins", []):
                if p["layer"] == old:
                    p["layer"] = new
            for k in doc.get("links", []):
                k["layers"] = [new if x == old else x for x in k["layers"]]
            for owner, t in _pin_tables(doc):
                owner[t] = {(new + k[len(old):] if _ext_layer(k) == old else k): v for k, v in owner[t].items()}
        return self._edit(Event("layer", new, "none", f"rename layer {old}"), m)

    @ck.checked(name=ck.text, fields=ck.plain)
    def set_layer(self, name: str, **fields) -> bool:
        """Change a layer's ``offset``, ``mask``, ``order``, ``inpaint``, ``mesh``,
        ``exterior``, ``deformer`` ({"mode": ...}), ``stiffness`` ({"file": ...}) or
        ``visible`` (scene-format values; None removes the key, back to its default)."""
        def m(doc):
            L = self._layer(doc, name)
            for k, v in _layer_fields(fields, keep_none=True).items():
                if v is None or (k == "visible" and v is True):  # (shown: the default, no key)
                    L.pop(k, None)
                else:
                    L[k] = v
        what = "change" if set(fields) != {"visible"} else "show" if fields["visible"] in (True, None) else "hide"
        return self._edit(Event("layer", name, "mesh", f"{what} layer {name}"), m)

    @ck.checked(name=ck.text, mask=ck.plain)
    def set_mask(self, name: str, mask) -> bool:
        """A layer's mask: ``"alpha"`` or ``{"threshold": T}``, ``{"polygon": ...}``, ``{"rect": ...}``,
        ``{"file": path}``, ``{"grabcut": ...}``."""
        return self.set_layer(name, mask=mask)

    @ck.checked(name=ck.text, cage=ck.plain, vertices=ck.optional(ck.plain))
    def set_cage(self, name: str, cage, *, vertices=None) -> bool:
        """A layer's cage (one undo step): ``{"points": [[x, y], ...]}`` or ``{"auto": N,
        "offset": PX}``, with ``"coordinates"`` (scene format, ``layers[i].cage``), or None
        to remove it. Targets of its handles ``LAYER:cageN`` in poses and keys that the new
        cage has no vertex for are dropped (all of them with None; an automatic cage
        without points keeps them, checked when the scene is built).

        ``vertices``: for new ``points``, per point the number of the old vertex it is
        (None for an added one), as the app gives it when it adds or deletes a vertex: the
        targets of each old handle then follow its vertex to its new number, and those of
        the vertices left out are dropped (without it, handles keep their numbers)."""
        count = 0 if cage is None else len(cage["points"]) if isinstance(cage, dict) and isinstance(
            cage.get("points"), list) else None
        new_name = self._cage_renumbering(name, vertices, count)

        def m(doc):
            L = self._layer(doc, name)
            if cage is None:
                L.pop("cage", None)
            else:
                L["cage"] = cage
            if count is None:
                return
            for owner, t in _pin_tables(doc):
                renamed = {new_name(k): v for k, v in owner[t].items()}
                owner[t] = {k: v for k, v in renamed.items() if k is not None and not _cage_beyond(k, name, count)}
        return self._edit(Event("layer", name, "mesh", f"{'remove' if cage is None else 'set'} cage of {name}"), m)

    def _cage_renumbering(self, name: str, vertices, count: int | None):
        """The handle name -> new handle name (None: dropped) function of :meth:`set_cage`'s
        ``vertices``; refused in one line where it does not fit the new points."""
        if vertices is None:
            return lambda k: k
        ok = (count is not None and isinstance(vertices, list) and len(vertices) == count
              and all(v is None or (isinstance(v, int) and not isinstance(v, bool) and v >= 0) for v in vertices))
        olds = [v for v in vertices if v is not None] if ok else []
        if not ok or len(set(olds)) != len(olds):
            raise SceneError(f"set_cage: vertices must give, per new cage point ({count}), the number of the old "
                             f"vertex it is or null, each old vertex at most once; got {vertices!r}"[:300],
                             file=self.file)
        to = {old: j for j, old in enumerate(vertices) if old is not None}

        def new_name(k: str) -> str | None:
            mt = CAGE_NAME.match(k)
            if not mt or mt.group("layer") != name:
                return k
            j = to.get(int(mt.group("i")))
            return None if j is None else f"{name}:cage{j}"
        return new_name

    @ck.checked(name=ck.text, method=ck.text)
    def set_inpaint(self, name: str, method: str) -> bool:
        return self.set_layer(name, inpaint=method)

    @ck.checked(name=ck.text, options=ck.plain)
    def set_mesh_options(self, name: str, **options) -> bool:
        """A layer's ``max_area``, ``min_angle``, ``simplify`` (None: back to the default)."""
        L = self._layer(self._doc, name)
        mesh = dict(L.get("mesh", {}))
        for k, v in options.items():
            if v is None:
                mesh.pop(k, None)
            else:
                mesh[k] = v
        return self.set_layer(name, mesh=mesh or None)

    @ck.checked(name=ck.text, mask=ck.layer_grid(ck.pixels("a mask", lo=0, hi=255)))
    def set_mask_pixels(self, name: str, mask) -> bool:
        """A layer's mask as pixels: ``mask`` (h, w) bool in the layer image's grid (the
        source's for a layer without its own image). Kept as a PNG until :meth:`save`
        writes it beside the scene (``mask: {"file": ...}``)."""
        with self.pending.staged():  # a refused mask leaves no PNG behind
            return self.set_mask(name, {"file": self.pending.add(mask_rgba(mask), f"{name}-mask")})

    @ck.checked(name=ck.text, rgba=ck.pixels("layer pixels", 4))
    def set_layer_pixels(self, name: str, rgba) -> bool:
        """A layer's own pixels ((h, w, 4) uint8, placed at its offset): a repainted or
        cloned layer. Kept as a PNG until :meth:`save` writes it beside the scene."""
        self._layer(self._doc, name)  # an unknown layer is refused before a PNG is written
        def m(doc):
            self._layer(doc, name)["image"] = path
        with self.pending.staged():  # refused pixels (e.g. all transparent) leave no PNG behind
            path = self.pending.add(rgba if rgba.dtype == np.uint8 else np.rint(rgba), name)
            return self._edit(Event("layer", name, "mesh", f"paint layer {name}"), m)

    @ck.checked(layer=ck.text, region=ck.anything, name=ck.text, cut=ck.flag)
    def split_layer(self, layer: str, region, name: str, *, cut: bool = True) -> bool:
        """Layer via Cut (or, ``cut=False``, via Copy): the pixels of ``layer`` inside
        ``region`` (a polygon, list of [x, y] canvas points, or an (H, W) bool mask of the
        canvas) become a new layer ``name`` in front of it; a cut takes them out of
        ``layer``, refilling it where the part covered its body (:mod:`puppet.scene.document.split`)."""
        from puppet.scene.document.split import split_layer  # lazy: the split and its inpainting, for this edit only

        with self.pending.staged():  # a refused split leaves none of its PNGs behind
            return split_layer(self, layer, region, name, cut)

    # a whole rig --------------------------------------------------------------------
    @ck.checked(pins=ck.plain, links=ck.plain, deformer=ck.plain)
    def add_rig(self, pins, links, deformer=None) -> bool:
        """Add ``pins`` and ``links`` (lists in the scene file's form, e.g. the proposal of
        :func:`puppet.scene.make.anatomy.rig_scene`) in one step, labelled "rig
        automatically": a pin whose name is taken and a link between two layers already
        linked are left out. ``deformer`` (the file's form) is set only when the scene has
        none."""
        if not (isinstance(pins, list) and all(isinstance(p, dict) for p in pins)
                and isinstance(links, list) and all(isinstance(k, dict) for k in links)
                and (deformer is None or isinstance(deformer, dict))):
            raise self._fail("add_rig: pins and links must be lists of objects and deformer an object or None, "
                             "in the scene file's form")

        def pair(k: dict):
            L = k.get("layers")
            return frozenset(L) if isinstance(L, list) and all(isinstance(n, str) for n in L) else None

        def m(doc):
            taken = {p["name"] for p in doc.get("pins", [])}
            linked = {pair(k) for k in doc.get("links", [])}
            new_pins = [dict(p) for p in pins if not (isinstance(p.get("name"), str) and p["name"] in taken)]
            new_links = [dict(k) for k in links if pair(k) is None or pair(k) not in linked]
            if new_pins:
                doc["pins"] = doc.get("pins", []) + new_pins
            if new_links:
                doc["links"] = doc.get("links", []) + new_links
            if (new_pins or new_links) and deformer is not None and "deformer" not in doc:
                doc["deformer"] = dict(deformer)
        return self._edit(Event("rig", "", "mesh", "rig automatically"), m)

    # links --------------------------------------------------------------------------
    @ck.checked(a=ck.text, b=ck.text, segment=ck.points(2, 2))
    def add_link(self, a: str, b: str, segment) -> bool:
        """A link segment ``[[x0, y0], [x1, y1]]`` between layers ``a`` and ``b``."""
        seg = [_xy(segment[0]), _xy(segment[1])]

        def m(doc):
            links = doc.setdefault("links", [])
            for k in links:
                if set(k["layers"]) == {a, b}:
                    k["segments"].append(seg)
                    return
            links.append({"layers": [a, b], "segments": [seg]})
        return self._edit(Event("link", f"{a}+{b}", "mesh", f"link {a} and {b}"), m)

    @ck.checked(a=ck.text, b=ck.text, segment=ck.optional(ck.integer(0, 10 ** 9)))
    def remove_link(self, a: str, b: str, segment: int | None = None) -> bool:
        """Remove segment number ``segment`` of the link between ``a`` and ``b`` (all when None)."""
        def m(doc):
            links = doc.get("links", [])
            for k in links:
                if set(k["layers"]) == {a, b}:
                    if segment is not None and len(k["segments"]) > 1:
                        if not 0 <= segment < len(k["segments"]):
                            raise self._fail(f"the link {a}-{b} has no segment {segment}")
                        del k["segments"][segment]
                    else:
                        links.remove(k)
                    return
            raise self._fail(f"no link between {a!r} and {b!r}")
        return self._edit(Event("link", f"{a}+{b}", "mesh", f"unlink {a} and {b}"), m)

    # poses ----------------------------------------------------------------------------
    @ck.checked(name=ck.text, like=ck.optional(ck.text), activate=ck.flag)
    def add_pose(self, name: str, *, like: str | None = None, activate: bool = True) -> bool:
        """A new pose (empty, or a copy of pose ``like``), made active unless ``activate=False``."""
        def m(doc):
            poses = doc.setdefault("poses", {})
            if name in poses or name == "rest":
                raise self._fail(f"a pose named {name!r} exists already")
            if like not in (None, "rest") and like not in poses:
                raise self._fail(f"no pose named {like!r} to copy")
            poses[name] = dict(poses[like]) if like not in (None, "rest") else {}
            return name if activate else None
        return self._edit(Event("pose", name, "solve", f"add pose {name}"), m)

    @ck.checked(old=ck.text, new=ck.text)
    def rename_pose(self, old: str, new: str) -> bool:
        """Rename a pose (and its animation keys)."""
        def m(doc):
            poses = doc.get("poses", {})
            if old not in poses:
                raise self._fail(f"no pose named {old!r}")
            if new in poses and new != old or new == "rest":
                raise self._fail(f"a pose named {new!r} exists already")
            doc["poses"] = {(new if k == old else k): v for k, v in poses.items()}
            for key in doc.get("animation", {}).get("keys", []):
                if key.get("pose") == old:
                    key["pose"] = new
            return new if self._active == old else None
        return self._edit(Event("pose", new, "none", f"rename pose {old}"), m)

    @ck.checked(name=ck.text)
    def delete_pose(self, name: str) -> bool:
        """Delete a pose and the animation keys that show it."""
        def m(doc):
            if name not in doc.get("poses", {}):
                raise self._fail(f"no pose named {name!r}")
            del doc["poses"][name]
            anim = doc.get("animation")
            if anim is not None:
                anim["keys"] = [k for k in anim["keys"] if k.get("pose") != name]
                if not anim["keys"]:
                    del doc["animation"]
            return "rest" if self._active == name else None
        return self._edit(Event("pose", name, "solve", f"delete pose {name}"), m)

    @ck.checked(name=ck.text)
    def set_active_pose(self, name: str) -> bool:
        """Show and edit pose ``name`` (``"rest"`` included)."""
        if name != "rest" and name not in self.data.poses:
            raise self._fail(f"no pose named {name!r}")
        return self._edit(Event("active", name, "solve", f"show pose {name}"), lambda doc: name)

    @ck.checked(pin=ck.text, to=ck.optional(ck.point), angle=ck.optional(ck.COORD), depth=ck.optional(ck.COORD),
                pose=ck.optional(ck.text))
    def set_target(self, pin: str, to=None, *, angle: float | None = None, depth: float | None = None,
                   pose: str | None = None) -> bool:
        """Where pose ``pose`` (default: the active one) puts ``pin``: target, angle, depth.
        Editing the ``rest`` pose makes a new pose and makes it active."""
        def m(doc):
            self._check_target_name(pin)
            table, made = self._pose_of(doc, pose)
            t = table.get(pin)
            t = {"to": t} if isinstance(t, list) else dict(t or {})
            if to is not None:
                t["to"] = _xy(to)
            if angle is not None:
                t["angle"] = float(angle)
            if depth is not None:
                t["depth"] = float(depth)
            table[pin] = t["to"] if set(t) == {"to"} else t
            return made
        return self._edit(Event("target", pin, "solve", f"move {pin}"), m)

    @ck.checked(pin=ck.text, pose=ck.optional(ck.text))
    def clear_target(self, pin: str, *, pose: str | None = None) -> bool:
        """Put ``pin`` back at rest in pose ``pose`` (default: the active one)."""
        def m(doc):
            name = self._active if pose is None else pose
            if name != "rest":
                doc.get("poses", {}).get(name, {}).pop(pin, None)
        return self._edit(Event("target", pin, "solve", f"reset {pin}"), m)

    def _check_target_name(self, pin: str) -> None:
        if pin in {p.name for p in self.data.pins}:
            return
        if not any(pin in ge.names for ge in self.built.exterior):
            raise self._fail(f"no pin or exterior point named {pin!r}")

    # app-only settings ----------------------------------------------------------------
    @ck.checked(image=ck.optional(ck.path), opacity=ck.number(0, 1), offset=ck.point,
                scale=ck.number(1e-3, 1e3, lo_open=True))
    def set_underlay(self, image: str | None, *, opacity: float = 0.5, offset=(0.0, 0.0), scale: float = 1.0) -> bool:
        """The reference picture drawn under the canvas by the app (None removes it);
        stored under the scene's ``app`` key, which render ignores."""
        if image is not None:  # a missing or bad picture is refused before anything changes
            load_rgba(os.path.abspath(image), scene_file=self.file, json_path="app.underlay.image")

        def m(doc):
            app = doc.setdefault("app", {})
            if image is None:
                app.pop("underlay", None)
            else:
                app["underlay"] = underlay_json(image, opacity, offset, scale)
            if not app:
                del doc["app"]
        return self._edit(Event("app", "underlay", "none", "set underlay"), m)

    # deformer (animation keys: puppet.scene.document.key_edits) ---------------------------------------
    @ck.checked(options=ck.plain)
    def set_deformer(self, **options) -> bool:
        """Deformer options: ``method``, ``weights``, ``init``, ``iterations``, ``alpha``, ``relax_foldovers``."""
        def m(doc):
            d = doc.setdefault("deformer", {})
            d.update(options)
        return self._edit(Event("deformer", "", "precompute", "change deformer"), m)


def _pin_tables(doc: dict) -> list[tuple[dict, str]]:
    """Every table of pin targets in the scene JSON as (owner, key): each pose, and the
    ``pins`` or ``overrides`` of each animation key."""
    out = [(doc["poses"], name) for name in doc.get("poses", {})]
    return out + [(k, f) for k in doc.get("animation", {}).get("keys", []) for f in ("pins", "overrides") if f in k]


def _ext_layer(name: str) -> str | None:
    """The layer of an automatic point name (``LAYER:extN``, ``LAYER:cageN``), else None."""
    mt = EXTERIOR_NAME.match(name) or CAGE_NAME.match(name)
    return mt.group("layer") if mt else None


def _cage_beyond(name: str, layer: str, count: int) -> bool:
    """Is ``name`` a handle ``LAYER:cageN`` of ``layer`` with N >= count?"""
    mt = CAGE_NAME.match(name)
    return bool(mt) and mt.group("layer") == layer and int(mt.group("i")) >= count


def _layer_fields(fields: dict, keep_none: bool = False) -> dict:
    known = ("offset", "mask", "order", "inpaint", "mesh", "exterior", "deformer", "stiffness", "visible", "cage")
    out = {}
    for k, v in fields.items():
        if k not in known:
            raise SceneError(f"a layer has no field {k!r} (fields: {', '.join(known)})")
        if v is None and not keep_none:
            continue
        if k == "offset" and isinstance(v, list) and len(v) == 2 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
            v = _xy(v)  # numbers as floats; anything else is reported by the validation, with its path
        if k in ("mask", "stiffness") and isinstance(v, dict) and isinstance(v.get("file"), str):
            v = dict(v, file=os.path.abspath(v["file"]))
        out[k] = v
    return out
