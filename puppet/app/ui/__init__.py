"""The Dear ImGui user interface: the action table (:mod:`.actions`: every key, menu item
and tooltip), the menu bar, toolbar, status line and modal dialogs (:mod:`.menus`), the side
panels, the Deform, History and timeline panels, the export dialog, the start page, the
task script's step bar and panels (:mod:`.script`), file dialogs (:mod:`.files`), and what
is drawn over the canvas (:mod:`.overlay`, :mod:`.deform_overlay`).

Imports: ``app.tools``, ``app.model``, imgui_bundle; not ``app.gl``.
"""
