"""Which reader opens a layered art file: picked by the file's suffix."""
from __future__ import annotations

import os

from puppet.errors import ImageError
from puppet.imaging.layered.art import LayeredArt, check_regular

#: File name suffixes read as layered art, and the reader of each.
SUFFIXES = {".psd": "psd", ".psb": "psd", ".ora": "ora", ".kra": "kra"}



def is_layered(path: str) -> bool:
    """Whether ``path`` names a layered art file (by its suffix)."""
    return os.path.splitext(path)[1].lower() in SUFFIXES


def read_layered(path: str) -> LayeredArt:
    """Read a PSD, PSB, ORA or KRA file (chosen by suffix) as layers.

    Returns
    -------
    LayeredArt with at least one layer.

    Raises
    ------
    ImageError
        Missing or unreadable file, not of its kind, truncated, an unsupported colour
        mode or depth, too large, or nothing visible to import.
    """
    kind = SUFFIXES.get(os.path.splitext(path)[1].lower())
    if kind is None:
        raise ImageError("not a layered art file (.psd, .psb, .ora or .kra expected)", file=path)
    check_regular(path)
    if kind == "psd":
        from puppet.imaging.layered.psd import read_psd as read  # lazy: reader by suffix
    elif kind == "ora":
        from puppet.imaging.layered.ora import read_ora as read  # lazy: reader by suffix
    else:
        from puppet.imaging.layered.kra import read_kra as read  # lazy: reader by suffix
    art = read(path)
    if art.hidden:
        art.notes.append(f"{len(art.hidden)} hidden layer(s) or group(s) kept hidden (`visible: false`): "
                         + ", ".join(art.hidden[:6]) + (", ..." if len(art.hidden) > 6 else ""))
    if not any(lay.visible for lay in art.layers):
        why = "every layer is hidden" if art.hidden else "no visible pixel layer"
        raise ImageError(f"nothing to import: {why}", file=path)
    return art
