"""Limits and parsing of ``puppet animate``'s options that need no numpy: read by the
command line's parser and by batch job lists as well as by the export itself."""
from __future__ import annotations

from puppet.errors import SceneError

#: Frame rates accepted, frames per second.
MIN_FPS, MAX_FPS = 0.01, 240.0


def parse_background(text: str) -> str | tuple[int, int, int, int]:
    """``transparent``, or a colour: ``#rgb``, ``#rrggbb``, ``#rrggbbaa``, a CSS colour
    name (``white``, ``darkslategray``, ...) or ``rgb(r, g, b)`` -> RGBA 0..255 tuple.

    Raises
    ------
    SceneError
        Anything else (one line naming the flag).
    """
    t = text.strip().lower()
    if t in ("transparent", "none"):
        return "transparent"
    from PIL import ImageColor  # lazy: Pillow, only for a colour name

    try:
        r, g, b, a = ImageColor.getcolor(t, "RGBA")
    except ValueError:
        raise SceneError(f"{text!r} is not a colour: give transparent, #rrggbb, #rrggbbaa or a colour "
                         "name such as white") from None
    if not all(0 <= v <= 255 for v in (r, g, b, a)):  # Pillow passes rgb(300,0,0), hsl(0,0%,150%) through
        raise SceneError(f"{text!r} is out of range: channels are 0..255 (0..100% for percentages)")
    return int(r), int(g), int(b), int(a)
