"""GL and the window: the pyglet window that lays out each frame (:mod:`.window`), the
canvas (:mod:`.canvas`: checkerboard, background, underlay, the composited layers, mesh
views), Dear ImGui's renderer on moderngl (:mod:`.imgui_renderer`), pyglet input to ImGui
(:mod:`.keys`), and the onion skin's ghosts (:mod:`.ghosts`).

Imports: every other room of ``app``, ``puppet.render``, moderngl, pyglet, imgui_bundle.
"""
