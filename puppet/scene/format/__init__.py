"""The scene file (format v1 and its compatible extensions): strict JSON reading
(:mod:`.reader`), validators that know their JSON path (:mod:`.schema`), the validated
data model (:mod:`.model`, built by :mod:`.load`), the animation section, the app's keys,
a video source, the files a scene reads (:mod:`.inputs`), and the one writer
(:mod:`.write`).

Imports: ``puppet.errors`` and ``puppet.imaging`` only; every other room imports this one.
"""
