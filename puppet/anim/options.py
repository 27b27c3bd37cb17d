"""Limits and parsing of ``puppet animate``'s options that need no numpy: read by the
command line's parser and by batch job lists as well as by the export itself."""
from __future__ import annotations

import numbers
import os

from puppet.errors import SceneError

#: Frame rates accepted, frames per second.
MIN_FPS, MAX_FPS = 0.01, 240.0
#: Default ``--tolerance`` of the keyed mesh exports (Spine, the web player), canvas
#: pixels: the most a replayed frame may differ from puppet's; 0 keeps every frame.
KEY_TOLERANCE = 1.0
#: Largest ``--tolerance`` accepted, pixels.
MAX_TOLERANCE = 100.0


def parse_tolerance(value, flag: str = "--tolerance", what: str = "0: a key on every frame") -> float:
    """A ``--tolerance`` (or ``flag``) given by a user: pixels, 0..:data:`MAX_TOLERANCE`
    (a number or its text). Raises SceneError (one line)."""
    try:
        tol = float(value.strip() if isinstance(value, str) else value)
    except (TypeError, ValueError):
        raise SceneError(f"{flag} {value!r} is not a number of pixels") from None
    if isinstance(value, bool) or not 0.0 <= tol <= MAX_TOLERANCE:
        raise SceneError(f"{flag} {value!r}: give pixels 0..{MAX_TOLERANCE:g} ({what})")
    return tol


def parse_simplify(value) -> float:
    """A ``--simplify`` given by a user: pixels over 0, at most :data:`MAX_TOLERANCE`."""
    tol = parse_tolerance(value, "--simplify", "over 0: how far the lighter meshes may draw from puppet's")
    if tol == 0:
        raise SceneError(f"--simplify {value!r}: give pixels over 0 (how far the lighter meshes may draw from "
                         "puppet's); leave it out for the layers' own meshes")
    return tol


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


#: Most worker (solver) processes a command line may ask for (``--workers``, also batch's).
MAX_WORKERS = 1024
#: Memory counted per worker process when capping a worker count: a batch worker holding
#: a few scenes and a GL context measured 90-400 MB, an export's solver process holds one
#: built scene; animations and large canvases need more.
WORKER_BYTES = 512 * 1024 * 1024


def default_workers() -> int:
    """One worker per core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def available_memory() -> int | None:
    """Bytes of memory this process may still use: the system's available memory, or the
    cgroup's limit left when lower; None when unknown."""
    found = []
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as f:
            limit = f.read().strip()
        with open("/sys/fs/cgroup/memory.current", encoding="ascii") as f:
            used = int(f.read().strip())
        if limit != "max":
            found.append(max(0, int(limit) - used))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def worker_cap() -> tuple[int, int, int | None]:
    """``(cap, cores, memory)``: the most worker processes this machine runs at once (one
    per core and one per :data:`WORKER_BYTES` of available memory, at least one), the
    cores and the available memory in bytes (None: unknown). Batch's workers and an
    export's solver processes are capped alike."""
    cores = default_workers()
    memory = available_memory()
    by_memory = max(1, memory // WORKER_BYTES) if memory else cores
    return max(1, min(cores, by_memory)), cores, memory


def parse_workers(value, what: str = "") -> int:
    """A worker count given by a user: a whole number 1..:data:`MAX_WORKERS` (an integer,
    numpy's too, or its decimal text; not a bool). Raises SceneError (one line, ``what`` before the value)."""
    if isinstance(value, str):
        try:
            value = int(value.strip())
        except ValueError:
            raise SceneError(f"{what}{value!r} is not a whole number") from None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 1 <= value <= MAX_WORKERS:
        raise SceneError(f"{what}{value!r}: give a whole number of processes 1..{MAX_WORKERS}")
    return int(value)
