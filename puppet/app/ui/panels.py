"""The side panels: Layers (stacking order, thumbnails, visibility, drag to reorder, mesh
options and inpainting of the selected layer), Poses, Pins, Reference picture, History."""
from __future__ import annotations

import os

from imgui_bundle import imgui

from puppet.app.ui import deform_panel as deformpanel
from puppet.app.ui import history_panel, script
from puppet.app.ui.widgets import THUMB, button, live, note, toggle
from puppet.scene.format.model import INPAINT_METHODS
from puppet.scene.rig.build import default_max_area
from puppet.scene.rig.stiffness import STARCH_RADIUS

_H = imgui.TreeNodeFlags_.default_open


class Panels:
    """Draws the side panels of ``app`` (an :class:`~puppet.app.model.app.App`)."""

    def __init__(self, app, thumbs):
        self.app = app
        self.thumbs = thumbs
        self.pose_name = ""
        self.pin_name = ""
        self.underlay_path = ""
        self._auto_area: dict[str, float] = {}
        self._sizes: dict[str, tuple[int, int]] = {}  # layer -> (vertices, triangles) of its exact mesh
        self._had_underlay = False

    def draw(self) -> None:
        app = self.app
        if not app.snap.loaded:
            imgui.text_wrapped("No scene. File > Open (Ctrl+O) opens one.")
            return
        script.panel(app, self.thumbs)
        if app.script.step == "link":
            deformpanel.link_step_tools(app)
        if imgui.collapsing_header("Layers", _H):
            self.layers()
        if imgui.collapsing_header("Poses", _H):
            self.poses()
        if imgui.collapsing_header("Pins", _H):
            self.pins()
        deform = imgui.collapsing_header("Deform")
        note("header:Deform")
        if deform:
            deformpanel.panel(app)
        has = app.snap.underlay is not None
        if has and not self._had_underlay:  # a picture was just set: show its settings
            imgui.set_next_item_open(True)
        self._had_underlay = has
        opened = imgui.collapsing_header("Reference picture")
        note("header:Reference picture")
        if opened:
            self.reference()
        opened = imgui.collapsing_header("History")
        note("header:History")
        if opened:
            history_panel.draw(app)

    # -- layers ---------------------------------------------------------------------
    def layers(self) -> None:
        app, snap = self.app, self.app.snap
        order = sorted(range(len(snap.layers)), key=lambda k: -snap.rank[k])  # front first
        imgui.text_disabled("front")
        for k in order:
            name = snap.data.layers[k].name
            imgui.push_id(f"layer-{name}")
            shown = snap.data.layers[k].visible
            vis = toggle("##vis", shown, "show or hide the layer (saved: a hidden layer moves with its pins and "
                         "links but is not drawn, nor exported)")
            note(f"visible:{name}")
            if vis != shown:
                app.edit(lambda s, name=name, vis=vis: s.set_layer(name, visible=vis))
            imgui.same_line()
            im = snap.images[k]
            imgui.image(*self.thumbs.ref(snap.image_keys[k], im.rgba))
            imgui.same_line()
            r = snap.layers[k]
            if not snap.preview or name not in self._sizes:  # a big drag's previews are coarse meshes
                self._sizes[name] = (len(r.rest), len(r.triangles))
            nv, nt = self._sizes[name]
            clicked, _ = imgui.selectable(f"{name}\n{nv} vertices, {nt} triangles",
                                         app.selected_layer == name, 0, imgui.ImVec2(0, THUMB))
            imgui.set_item_tooltip("select; drag onto another layer to move it there in the stacking order")
            note(f"layer:{name}")
            if clicked:
                app.selected_layer = name
            if imgui.begin_drag_drop_source():
                imgui.set_drag_drop_payload_py_id("LAYER", k)
                imgui.text(f"move {name}")
                imgui.end_drag_drop_source()
            if imgui.begin_drag_drop_target():
                payload = imgui.accept_drag_drop_payload_py_id("LAYER")
                if payload is not None and payload.data_id != k:
                    moving = snap.data.layers[payload.data_id].name
                    app.edit(lambda s, moving=moving, k=k: s.reorder_layer(moving, k))
                imgui.end_drag_drop_target()
            imgui.pop_id()
        imgui.text_disabled("back")
        k = app.layer_index(app.selected_layer)
        if k is not None:
            imgui.separator()
            self.layer_options(k)

    def layer_options(self, k: int) -> None:
        app, snap = self.app, self.app.snap
        L = snap.data.layers[k]
        name = L.name
        imgui.text(f"Layer {name}")
        key = snap.image_keys[k]
        if key not in self._auto_area:
            self._auto_area[key] = default_max_area(snap.images[k].mask)
        auto = L.mesh.max_area is None
        area = self._auto_area[key] if auto else L.mesh.max_area
        log = imgui.SliderFlags_.logarithmic
        sliders = (  # option, label, value, range, format, flags, tooltip
            ("max_area", "triangle size", area, (2.0, 4000.0), "%.0f px²", log,
             "mesh density: largest triangle area (smaller = denser mesh); re-meshes live"),
            ("min_angle", "min angle", L.mesh.min_angle, (0.0, 34.0), "%.0f°", 0,
             "smallest triangle angle (higher = rounder triangles, more of them)"),
            ("simplify", "simplify", L.mesh.simplify, (0.0, 8.0), "%.1f px", 0,
             "outline simplification tolerance (Douglas-Peucker), pixels"))
        for option, label, value, (lo, hi), fmt, flags, tip in sliders:
            changed, value = imgui.slider_float(label, value, lo, hi, fmt, flags)
            imgui.set_item_tooltip(tip)
            note(f"slider:{label}")
            live(app, "mesh", f"{label} of {name}")
            if changed:
                app.edit(lambda s, o=option, v=value: s.set_mesh_options(name, **{o: float(v)}),
                         key="mesh-live")
        if button("Reset mesh", "back to the default mesh options (density chosen from the layer size)",
                  enabled=not auto or L.mesh.min_angle != 25.0 or L.mesh.simplify != 1.0):
            app.edit(lambda s: s.set_layer(name, mesh=None))
        items = list(INPAINT_METHODS)
        changed, i = imgui.combo("inpaint", items.index(L.inpaint), items)
        imgui.set_item_tooltip("how this layer refills the pixels that layers in front of it took from the "
                               "same source picture")
        if changed:
            app.edit(lambda s, m=items[i]: s.set_inpaint(name, m))

    # -- poses ----------------------------------------------------------------------
    def poses(self) -> None:
        app, snap = self.app, self.app.snap
        for name in snap.poses:
            label = "rest  (read-only)" if name == "rest" else name
            clicked, _ = imgui.selectable(f"{label}##pose-{name}", snap.active == name)
            imgui.set_item_tooltip("show and edit this pose" if name != "rest" else
                                   "the rest pose; dragging a pin here makes a new pose")
            note(f"pose:{name}")
            if clicked:
                app.timeline.leave()  # the canvas shows the pose, not the animation
            if clicked and name != snap.active:
                app.edit(lambda s, n=name: s.set_active_pose(n))
                app.set_mode("pose")
        at_rest = snap.active == "rest"
        if button("New", "a new empty pose (every pin at rest), made active"):
            n = self._free_name("pose")
            app.edit(lambda s: s.add_pose(n))
            app.set_mode("pose")
        imgui.same_line()
        if button("Duplicate", "a copy of the active pose, made active", enabled=not at_rest):
            n = self._free_name(snap.active + " copy")
            app.edit(lambda s, like=snap.active: s.add_pose(n, like=like))
        imgui.same_line()
        if button("Delete", "delete the active pose (and its animation keys)", enabled=not at_rest):
            app.edit(lambda s, n=snap.active: s.delete_pose(n))
        imgui.set_next_item_width(150)
        if at_rest:
            self.pose_name = ""
        enter, self.pose_name = imgui.input_text_with_hint("##pose-name", snap.active if not at_rest else "",
                                                          self.pose_name, imgui.InputTextFlags_.enter_returns_true)
        imgui.set_item_tooltip("new name for the active pose")
        note("field:pose name")
        imgui.same_line()
        if (button("Rename", "rename the active pose", enabled=not at_rest and bool(self.pose_name.strip()))
                or enter and not at_rest and self.pose_name.strip()):
            new = self.pose_name.strip()
            app.edit(lambda s, old=snap.active: s.rename_pose(old, new))
            self.pose_name = ""

    def _free_name(self, base: str) -> str:
        names = set(self.app.snap.poses)
        k, name = 1, base
        while name in names:
            k += 1
            name = f"{base} {k}"
        return name

    # -- pins -----------------------------------------------------------------------
    def pins(self) -> None:
        app, snap = self.app, self.app.snap
        imgui.text("new pins:")
        imgui.same_line()
        if imgui.radio_button("interior", app.pin_kind == "interior"):
            app.pin_kind = "interior"
        imgui.set_item_tooltip("pins inside a layer: the mesh follows them")
        imgui.same_line()
        if imgui.radio_button("exterior", app.pin_kind == "exterior"):
            app.pin_kind = "exterior"
        imgui.set_item_tooltip("boundary control points (blue diamonds): fine edits of the outline")
        note("radio:exterior")
        if button("Back [", "selected pins' depth -1: the region around them goes behind"):
            app.change_depth(-1.0)
        imgui.same_line()
        if button("Front ]", "selected pins' depth +1: the region around them comes in front"):
            app.change_depth(+1.0)
        imgui.same_line()
        if button("Remove", "remove the selected pins (Delete)", enabled=bool(app.selection)):
            app.remove_pins(list(app.selection))
        if len(app.selection) == 1:
            self.pin_details(app.selection[0])
        imgui.begin_child("pin-list", imgui.ImVec2(0, 110), imgui.ChildFlags_.borders)
        kinds = {p.name: p for p in snap.data.pins}
        for m in app.markers():
            p = kinds.get(m.name)
            text = f"{m.name}  [{m.kind}] {snap.data.layers[m.layer].name}" + (f" depth {p.depth:g}" if p else "")
            clicked, _ = imgui.selectable(f"{text}##pin-{m.name}", m.name in app.selection)
            if clicked:
                app.select(m.name, imgui.get_io().key_shift)
        imgui.end_child()

    def pin_details(self, name: str) -> None:
        app, snap = self.app, self.app.snap
        pin = next((p for p in snap.data.pins if p.name == name), None)
        if pin is not None:
            imgui.set_next_item_width(120)
            enter, self.pin_name = imgui.input_text_with_hint("##pin-name", name, self.pin_name,
                                                             imgui.InputTextFlags_.enter_returns_true)
            imgui.set_item_tooltip("type a new name and press Enter")
            if enter and self.pin_name.strip():
                new = self.pin_name.strip()
                app.edit(lambda s: s.rename_pin(name, new))
                app.selection = [new]
                self.pin_name = ""
            imgui.same_line()
            kinds = ["interior", "exterior", "starch"]
            imgui.set_next_item_width(90)
            changed, i = imgui.combo("kind", kinds.index(pin.kind), kinds)
            imgui.set_item_tooltip("interior pin, exterior (boundary) control point, or starch (stiffens, holds nothing)")
            note("combo:kind")
            if changed:
                app.edit(lambda s: s.set_pin(name, kind=kinds[i]))
            if pin.kind == "starch":  # stiffens around it, holds no position: no target, no angle
                imgui.same_line()
                imgui.text(f"radius {pin.radius or STARCH_RADIUS:g}")
                imgui.set_item_tooltip("a starch pin stiffens the shape around it; a pose cannot move it "
                                       "(its radius: Deform panel)")
                return
        if app.mode == "pose" and snap.active != "rest":
            t = snap.data.poses.get(snap.active, {}).get(name)
            angle = float(t.angle) if t is not None else 0.0
            imgui.set_next_item_width(120)
            changed, angle = imgui.drag_float("angle", angle, 0.5, -720.0, 720.0, "%.1f°")
            imgui.set_item_tooltip("the pin's turn in this pose, degrees counter-clockwise (Alt-drag on the canvas)")
            live(app, "angle", f"turn {name}")
            if changed:
                app.edit(lambda s, a=angle: s.set_target(name, angle=a), key="angle-live")
            imgui.same_line()
            if button("Reset", "put this pin back at rest in this pose", enabled=t is not None):
                app.edit(lambda s: s.clear_target(name))

    # -- reference picture ----------------------------------------------------------
    def set_underlay(self, path: str) -> None:
        """Use the picture at ``path`` as the reference (keeping its placement if one is set)."""
        u = self.app.snap.underlay
        path = os.path.abspath(os.path.expanduser(path))
        keep = dict(opacity=u["opacity"], offset=u["offset"], scale=u["scale"]) if u else {}
        self.app.edit(lambda s: s.set_underlay(path, **keep))

    def reference(self) -> None:
        app, snap = self.app, self.app.snap
        u = snap.underlay
        imgui.text_wrapped("A picture drawn under the layers while you work (saved in the scene's "
                           "\"app\" key; render ignores it).")
        if u is not None:
            imgui.text(os.path.basename(u["image"]))
        files = getattr(app, "files", None)
        imgui.set_next_item_width(110 if files is not None and files.native else 180)  # room for Browse...
        enter, self.underlay_path = imgui.input_text_with_hint("##underlay", "path to a picture", self.underlay_path,
                                                              imgui.InputTextFlags_.enter_returns_true)
        imgui.set_item_tooltip("a PNG or JPEG path (relative to the current folder, or absolute)")
        note("field:underlay")
        imgui.same_line()
        if button("Set", "use this picture as the reference", enabled=bool(self.underlay_path.strip())) or \
                (enter and self.underlay_path.strip()):
            self.set_underlay(self.underlay_path.strip())
            self.underlay_path = ""
        if files is not None and files.native:
            imgui.same_line()
            if button("Browse...##underlay", "choose the picture in a file dialog"):
                files.ask("picture", self.set_underlay, os.path.dirname(snap.file) + os.sep if snap.file else "")
        if u is None:
            return
        imgui.same_line()
        if button("Remove##underlay", "remove the reference picture"):
            app.edit(lambda s: s.set_underlay(None))

        def setter(**change):
            v = dict(opacity=u["opacity"], offset=u["offset"], scale=u["scale"], **change)
            return lambda s: s.set_underlay(u["image"], **v)
        changed, op = imgui.slider_float("opacity", float(u["opacity"]), 0.0, 1.0, "%.2f")
        imgui.set_item_tooltip("how strongly the reference shows through")
        note("slider:opacity")
        live(app, "underlay", "reference opacity")
        if changed:
            app.edit(setter(opacity=float(op)), key="underlay-live")
        changed, off = imgui.drag_float2("offset", list(map(float, u["offset"])), 1.0)
        imgui.set_item_tooltip("where the picture's top-left corner sits on the canvas (drag)")
        live(app, "underlay", "reference position")
        if changed:
            app.edit(setter(offset=[float(off[0]), float(off[1])]), key="underlay-live")
        changed, sc = imgui.drag_float("scale", float(u["scale"]), 0.005, 0.01, 100.0, "%.3f")
        imgui.set_item_tooltip("the picture's size on the canvas")
        live(app, "underlay", "reference scale")
        if changed:
            app.edit(setter(scale=max(float(sc), 0.01)), key="underlay-live")
