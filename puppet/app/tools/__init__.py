"""Canvas tools: generator functions over (app, event) that run from a press to its
release (napari's mouse drag callbacks). :func:`.dispatch.choose_tool` picks the tool for a
press: pan, the Pin tool, Pose mode's pin drag (:mod:`.gestures`), keying and recording
on the timeline (:mod:`.anim`), the task script's mask, clone and link tools (:mod:`.mask`,
:mod:`.link`), the Deform panel's stiffness brush, hinge and patch (:mod:`.deform`).

Imports: ``app.model`` and ``puppet.scene``; no GL, window or ImGui library (what a tool
shows over the canvas is drawn in ``app.ui``).
"""
