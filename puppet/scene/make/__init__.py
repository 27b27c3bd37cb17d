"""Making scenes: ``puppet init PICTURE`` (:mod:`.picture`), ``puppet init ART.psd|.ora|.kra``
and ``--update`` (:mod:`.art`), the re-import merge that keeps a rig (:mod:`.merge`),
File > Reload art (:mod:`.reload`), and links proposed where imported layers overlap
(:mod:`.auto_links`).

Imports: ``scene.document`` and everything below it, ``imaging``, ``puppet.output``.
"""
