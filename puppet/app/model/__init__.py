"""The app's model, apart from GL, windows and ImGui: :class:`.app.App` (view state and the
typed intents every tool and panel calls), the scene session (:mod:`.session`: the one
thread that owns the document, the drag and the frame cache, and publishes immutable
:mod:`.snapshot` s), the timeline (:mod:`.timeline`, :mod:`.onion`, :mod:`.record`), the
task script's state (:mod:`.steps`), the view transform, picking, opening files,
autosave, recent files and the export run.

Imports: ``puppet.scene``, ``puppet`` (the API), ``imaging``, ``puppet.output``; never
moderngl, pyglet or imgui_bundle (a contract and ``tests/test_imports.py`` check it).
"""
