"""``puppet app``: an OpenGL window to pin, pose and animate a puppet's layers.

Four rooms, each importing only the rooms below it (import-linter contracts in
``pyproject.toml`` check it, and that ``model`` and ``tools`` load no GL, window or
ImGui library)::

    gl/      the pyglet window, the canvas and ImGui renderers (moderngl), key input,
             the onion skin's drawing
    ui/      Dear ImGui: the action table, menus, toolbar, panels, dialogs, the start
             page, the task script's step bar, what is drawn over the canvas
    tools/   canvas tools: generators over (app, event) from press to release
    model/   the app's state and intents, the scene session (the one thread that owns
             the document), snapshots, the timeline, view, picking, recording, files

:func:`puppet.app.main.run` opens the window (``puppet app``). Nothing in puppet imports
this package but the CLI, lazily, so ``render`` and ``mesh`` never load pyglet or ImGui.
See ``docs/architecture.md``.
"""
