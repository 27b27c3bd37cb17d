"""Names of the files an export writes beside its output (no numpy: read by the
formats table, which the command line loads to build its parser)."""
from __future__ import annotations

import os


def sheet_atlas(path: str) -> str:
    """The JSON atlas beside a sprite sheet: ``OUT.png`` -> ``OUT.json``."""
    return os.path.splitext(path)[0] + ".json"


def spine_side(path: str) -> list[str]:
    """Beside Spine's ``NAME.json``: [``NAME.atlas``, ``NAME.png``] (the first page; more
    are ``NAME_2.png`` ...)."""
    stem = path[:-5] if path.lower().endswith(".json") else os.path.splitext(path)[0]
    return [stem + ".atlas", stem + ".png"]
