"""The File > Export dialog: output path (its extension picks the format), fps, time
range, background; the export runs in a child process (:mod:`puppet.app.model.exporter`) with
a progress bar, rate and time left, and can be cancelled."""
from __future__ import annotations

import os

from imgui_bundle import imgui

from puppet.anim import formats
from puppet.app.model.exporter import Export
from puppet.app.ui.widgets import button, close_button, message, note

TITLE = "Export animation"
FORMATS = formats.describe()
WIDTH = 440
BACKGROUNDS = ("scene", "transparent")


class ExportForm:
    """The dialog's fields and its :class:`Export` run."""

    def __init__(self):
        self.run = Export()
        self.path = ""
        self.fps = 24.0
        self.start = 0.0
        self.end = 1.0
        self.background = 0
        self.reported = None  # the run whose end the status line told

    def open(self, app) -> None:
        """Fill the fields from the scene (called when the dialog opens)."""
        t = app.timeline
        base = os.path.splitext(app.snap.file or os.path.join(os.getcwd(), "animation.json"))[0]
        if not self.path or self.run.state == "done":
            self.path = base + ".mp4"
        self.fps = t.fps
        keys = t.keys()
        self.start = min((float(k["time"]) for k in keys), default=0.0)
        self.end = t.duration()
        if self.run.state in ("done", "failed", "cancelled"):
            self.run = Export()
        app.dialog = "export"

    def options(self) -> dict:
        return {"fps": self.fps, "start": self.start, "end": self.end,
                "background": "transparent" if BACKGROUNDS[self.background] == "transparent" else None}


def form(app) -> ExportForm:
    f = getattr(app, "export_form", None)
    if f is None:
        f = app.export_form = ExportForm()
    return f


def open_dialog(app) -> None:
    if not app.snap.loaded:
        return
    if not app.timeline.keys():
        app.say("the scene has no animation to export: add keys in the timeline first (K)", "error")
        return
    form(app).open(app)


def draw(app) -> None:
    """The dialog's body (inside the modal popup opened by :func:`puppet.app.ui.menus.dialogs`)."""
    f = form(app)
    run = f.run
    busy = run.running
    imgui.begin_disabled(busy)
    imgui.text("Output file or folder/ (the extension picks the format):")
    files = getattr(app, "files", None)
    native = files is not None and files.native
    imgui.set_next_item_width(WIDTH - (90 if native else 0))
    _, f.path = imgui.input_text("##export-path", f.path)
    imgui.set_item_tooltip(FORMATS)
    note("export:path")
    if native:
        imgui.same_line()
        if button("Browse...##export", "choose the output file in a file dialog"):
            files.ask("export", lambda p: setattr(f, "path", p), f.path)
    imgui.push_text_wrap_pos(imgui.get_cursor_pos_x() + WIDTH)
    imgui.text_disabled(FORMATS)
    imgui.pop_text_wrap_pos()
    for label, attr, fmt, width in (("fps", "fps", "%g", 45), ("from", "start", "%.3g s", 55),
                                    ("to", "end", "%.3g s", 55)):
        imgui.align_text_to_frame_padding()
        imgui.text(label)
        imgui.same_line()
        imgui.set_next_item_width(width)
        _, v = imgui.input_float(f"##export-{attr}", float(getattr(f, attr)), 0, 0, fmt)
        setattr(f, attr, v)
        imgui.same_line()
    imgui.text("background")
    imgui.same_line()
    imgui.set_next_item_width(imgui.get_content_region_avail().x)
    _, f.background = imgui.combo("##export-background", f.background, list(BACKGROUNDS))
    imgui.set_item_tooltip("the scene's background, or transparent where the format allows (webm, apng, png, gif)")
    imgui.end_disabled()
    if run.state != "idle":
        frac = run.done / run.total if run.total else 0.0
        imgui.progress_bar(frac, imgui.ImVec2(WIDTH, 0), f"{run.done} / {run.total}" if run.total else "starting...")
        note("export:progress")
        if busy:
            imgui.text_disabled(run.eta() or "solving the first frames...")
        elif run.message:
            message(run.message, run.state == "failed", WIDTH)
    if not busy and run.message and f.reported is not run:  # the status line says how it ended
        f.reported = run
        app.say(run.message, "error" if run.state == "failed" else "info")
    if not busy:
        if button("Export", "write the animation (the scene as it is now, unsaved edits too)",
                  enabled=bool(f.path.strip())):
            run.start(app, f.path.strip(), **f.options())
            app.say(f"exporting to {run.output}...")
        imgui.same_line()
        close_button(app, "Close", run.message, run.state == "failed")
    elif button("Cancel", "stop the export (nothing is written)"):
        run.cancel()
