"""Edits of the deformation that fits real art (issue 22): a layer's painted stiffness
as pixels, starch pins' radius, and links' hinge points, patch polygons and strength.
A mixin of :class:`puppet.scene.document.core.Document`; each method is one undo step
(see :mod:`puppet.scene.document.edits`)."""
from __future__ import annotations

import numpy as np

from puppet.scene.document.history import Event
from puppet.scene.format import args as ck


def _xy(p) -> list[float]:
    return [float(p[0]), float(p[1])]


def stiffness_rgba(grey: np.ndarray) -> np.ndarray:
    """Grey levels (h, w) 0..255 as the stiffness PNG's pixels (h, w, 4): grey colour,
    opaque (see :func:`puppet.scene.rig.stiffness.stiffness_image`)."""
    g = np.clip(np.rint(np.asarray(grey, float)), 0, 255).astype(np.uint8)
    out = np.empty(g.shape + (4,), np.uint8)
    out[..., :3] = g[..., None]
    out[..., 3] = 255
    return out


class DeformEdits:
    """Edit methods for stiffness, starch pins and hinge / patch links (a mixin)."""

    @ck.checked(name=ck.text, grey=ck.optional(ck.layer_grid(ck.pixels("stiffness grey levels", lo=0, hi=255))))
    def set_stiffness_pixels(self, name: str, grey) -> bool:
        """Layer ``name``'s painted stiffness: ``grey`` (h, w) 0..255 in its image's grid;
        None, or all zero, removes it. Kept as a PNG until :meth:`save` writes it."""
        if grey is None or not np.any(np.asarray(grey) > 0):
            return self.set_layer(name, stiffness=None)
        with self.pending.staged():  # a refused stiffness leaves no PNG behind
            path = self.pending.add(stiffness_rgba(grey), f"{name}-stiffness")
            return self.set_layer(name, stiffness={"file": path})

    @ck.checked(name=ck.text, radius=ck.optional(ck.number(0, 1e4, lo_open=True)))
    def set_pin_radius(self, name: str, radius: float | None) -> bool:
        """A starch pin's reach in px (None: the default)."""
        def m(doc):
            p = self._pin(doc, name)
            if radius is None:
                p.pop("radius", None)
            else:
                p["radius"] = float(radius)
        return self._edit(Event("pin", name, "precompute", f"change pin {name}"), m)

    def _link_of(self, doc: dict, a: str, b: str, make: bool) -> dict:
        links = doc.setdefault("links", [])
        for k in links:
            if set(k["layers"]) == {a, b}:
                return k
        if not make:
            raise self._fail(f"no link between {a!r} and {b!r}")
        k = {"layers": [a, b]}
        links.append(k)
        return k

    @ck.checked(a=ck.text, b=ck.text, at=ck.point)
    def add_link_point(self, a: str, b: str, at) -> bool:
        """A hinge between layers ``a`` and ``b`` at canvas point ``at``: they share a
        vertex there and can turn about it (``links[i].points``)."""
        def m(doc):
            self._link_of(doc, a, b, True).setdefault("points", []).append(_xy(at))
        return self._edit(Event("link", f"{a}+{b}", "mesh", f"hinge {a} and {b}"), m)

    @ck.checked(a=ck.text, b=ck.text, polygon=ck.points(3))
    def add_link_polygon(self, a: str, b: str, polygon) -> bool:
        """A shared patch (``polygon``: [[x, y], ...], at least 3 points) between layers
        ``a`` and ``b`` that moves as one (``links[i].polygons``)."""
        poly = [_xy(p) for p in polygon]

        def m(doc):
            self._link_of(doc, a, b, True).setdefault("polygons", []).append(poly)
        return self._edit(Event("link", f"{a}+{b}", "mesh", f"patch {a} and {b}"), m)

    @ck.checked(a=ck.text, b=ck.text, kind=ck.choice(("segments", "points", "polygons")), index=ck.INDEX)
    def remove_link_part(self, a: str, b: str, kind: str, index: int) -> bool:
        """Remove part ``index`` of ``kind`` ("segments", "points": a hinge, "polygons": a
        patch) of the link between ``a`` and ``b``; the link goes with its last part."""
        what = {"segments": "segment", "points": "hinge", "polygons": "patch"}[kind]

        def m(doc):
            k = self._link_of(doc, a, b, False)
            parts = k.get(kind, [])
            if not 0 <= index < len(parts):
                raise self._fail(f"the link {a}-{b} has no {what} {index}")
            del parts[index]
            if not parts:
                k.pop(kind, None)
            if not any(k.get(x) for x in ("segments", "points", "polygons")):
                doc["links"].remove(k)
        return self._edit(Event("link", f"{a}+{b}", "mesh", f"remove {what} of {a} and {b}"), m)

    @ck.checked(a=ck.text, b=ck.text, strength=ck.number(0, 1))
    def set_link_strength(self, a: str, b: str, strength: float) -> bool:
        """The coupling across the link between ``a`` and ``b``, 0..1 (1: the default)."""
        def m(doc):
            k = self._link_of(doc, a, b, False)
            if float(strength) == 1.0:
                k.pop("strength", None)
            else:
                k["strength"] = float(strength)
        return self._edit(Event("link", f"{a}+{b}", "mesh", f"link strength {a} and {b}"), m)
