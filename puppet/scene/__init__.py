"""The scene: the document a user edits, from the file on disk to posed meshes.

Six rooms, each importing only the rooms below it (an import-linter contract in
``pyproject.toml`` checks it)::

    make/      new scenes: ``puppet init`` from a picture or layered art, art reload,
               automatic links
    document/  the editable Document: edits, animation keys, undo history, layer
               splitting, the drag solver child
    drag/      drag sessions (fast previews, an exact release) and the solver process
    time/      keyframe timing, per-pin tracks, pin states at a pose or a time, in-betweens
    rig/       a scene built for posing: layer images, meshes, linked groups, solvers
    format/    the scene file: strict reading, validation, the data model, writing

Below ``scene`` are ``deform``, ``imaging`` and ``geom``; nothing here imports GL, a
window, ``render``, ``anim`` or ``app``. See ``docs/architecture.md``.
"""
