"""The File > Retarget motion dialog (issue 35): a BVH clip's path, the projection, the
scale and in-place choices; Read finds the map of pins to joints automatically and shows
it beside the pins, each pin's joint a combo to correct; Write keys replaces the scene's
animation with the clip's keys (one undo step). The work is in
:mod:`puppet.app.model.retarget`."""
from __future__ import annotations

from imgui_bundle import imgui

from puppet.app.model import retarget as rt
from puppet.app.ui.widgets import button, close_button, message, note
from puppet.motion.retarget import SCALES

TITLE = "Retarget motion"
WIDTH = 440


def open_dialog(app) -> None:
    if not app.snap.loaded:
        return
    app.dialog = "retarget"


def draw(app) -> None:
    """The dialog's body (inside the modal popup of :func:`puppet.app.ui.menus.dialogs`)."""
    f = rt.form(app)
    imgui.text("Motion capture clip (.bvh):")
    files = getattr(app, "files", None)
    native = files is not None and files.native
    imgui.set_next_item_width(WIDTH - (160 if native else 70))
    entered, f.path = imgui.input_text_with_hint("##retarget-path", "a .bvh clip's path", f.path,
                                                 imgui.InputTextFlags_.enter_returns_true)
    note("retarget:path")
    imgui.same_line()
    if button("Read##retarget", "read the clip and find which joint each pin follows", enabled=bool(f.path.strip())) \
            or entered:
        rt.read(app, f)
    if native:
        imgui.same_line()
        if button("Browse...##retarget", "choose the clip in a file dialog"):
            files.ask("motion", lambda p: (setattr(f, "path", p), rt.read(app, f)), f.path)
    imgui.set_next_item_width(110)
    changed_p, f.projection = imgui.combo("projection##retarget", f.projection, list(rt.PROJECTION_CHOICES))
    imgui.set_item_tooltip("the plane the 3D motion is seen in: auto is sagittal for a character drawn in profile, "
                           "frontal otherwise; pca, the plane the motion moves most in")
    imgui.same_line()
    imgui.set_next_item_width(80)
    changed_s, f.scale = imgui.combo("scale##retarget", f.scale, list(SCALES))
    imgui.set_item_tooltip("body: one scale, by leg length; limbs: each limb by its own length (short arms swing short)")
    imgui.same_line()
    changed_i, f.in_place = imgui.checkbox("in place##retarget", f.in_place)
    imgui.set_item_tooltip("take the walk along the ground out (the character stays where it is)")
    if (changed_p or changed_s or changed_i) and f.motion is not None:
        rt.read(app, f)  # the map depends on the projection
    if f.error:
        message(f.error, True, WIDTH)
        note("retarget:error")
    if f.motion is not None:
        m = f.motion
        imgui.text_disabled(f"{m.count} frames, {m.count * m.frame_time:.2f} s, {len(m.names)} joints; "
                            "the pin on the left follows the joint on the right:")
        joints = [rt.NONE] + m.names
        for pin in list(f.map):
            imgui.align_text_to_frame_padding()
            imgui.text(pin)
            imgui.same_line(160)
            imgui.set_next_item_width(WIDTH - 160)
            cur = joints.index(f.map[pin]) if f.map[pin] in joints else 0
            changed, i = imgui.combo(f"##retarget-joint-{pin}", cur, joints)
            imgui.set_item_tooltip(f"the joint of the clip {pin} follows ((none): {pin} is not keyed)")
            note(f"retarget:joint:{pin}")
            if changed:
                f.map[pin] = joints[i]
    if button("Write keys", "replace the scene's animation with the clip's keys (one undo step)",
              enabled=f.motion is not None):
        if rt.write(app, f) is not None:
            app.dialog = None
            imgui.close_current_popup()
            return
    imgui.same_line()
    close_button(app, "Close##retarget")
