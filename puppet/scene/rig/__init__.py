"""The rig: a validated scene built for posing. Layer images and masks, meshes and linked
groups (:mod:`.build`), links as the meshes see them, exterior control points, per-cell
stiffness, each group's solver (:mod:`.solve`: precompute once, solve per pose), reduced
models for drag previews (:mod:`.reduced`), all cached under fingerprints of their
inputs (:mod:`.cache`, :class:`.core.Rig`).

Imports: ``scene.format``, ``geom``, ``deform``, ``imaging``, ``puppet.errors``.
"""
