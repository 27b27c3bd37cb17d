"""Time: keyframe timing and eases (:mod:`.timeline`), the animation's keys as per-pin
tracks (:mod:`.tracks`), where every pin is in a pose or at a time (:mod:`.evaluate`), and
the meshes of every layer at a time by the in-between mode (:mod:`.inbetween`).

Imports: ``scene.rig``, ``scene.format``, ``deform``, ``puppet.errors``; not ``scene.drag``.
"""
