"""The editable document: :class:`.core.Document` (the scene JSON now, its validated data,
rig and tracks, change events, load and save), its edits as mixins (:mod:`.edits`: pins,
layers, links, poses; :mod:`.key_edits`: animation keys; :mod:`.deform_edits`: stiffness,
hinges, patches), recorded motion written into keys, the undo history and events
(:mod:`.history`), pixels owned until saved (:mod:`.files`), Layer via Cut / Copy
(:mod:`.split`), and the drag solver child's side (:mod:`.drag_child`).

Imports: ``scene.drag``, ``scene.time``, ``scene.rig``, ``scene.format``, ``imaging``,
``puppet.output``, ``puppet.errors``.
"""
