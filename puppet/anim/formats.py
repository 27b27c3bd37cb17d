"""The one table of animation output formats.

Every place that lists or dispatches the formats of ``puppet animate`` reads
:data:`FORMATS`: the CLI (its ``-o`` help, ``--format`` choices and dispatch), the app's
Export dialog, and batch jobs. Adding a format is one :class:`Format` entry here (and its
sink).

Two families:

* **pixel** formats (``pixels=True``) take each composited frame, straight-alpha RGBA
  (h, w, 4) uint8, through the export's solve / composite / encode pipeline;
* **mesh** formats (``pixels=False``: the web player, Spine, glTF) take each frame's solved
  layers (:class:`puppet.scene.rig.core.LayerResult` list) and draw nothing: the deformed
  meshes, depths and the layer textures are what they write.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Callable

from puppet.anim.options import KEY_TOLERANCE
from puppet.anim.sidefiles import sheet_atlas, spine_side
from puppet.errors import SceneError

#: Options of ``animate_to`` that some formats cannot honour (the others always apply).
OPTIONS = ("size", "wireframe", "background", "tolerance", "simplify")
#: The options of a format that draws its frames.
DRAWN = frozenset({"size", "wireframe", "background"})


@dataclass
class Job:
    """What a sink needs to open: filled by :func:`puppet.anim.export.animate_to`.

    Attributes
    ----------
    output : the final path; tmp : the temporary path the sink writes (file or folder).
    size : (W, H) of the frames; fps : frame rate; start : time of frame 0; count : frames.
    alpha : the frames may hold transparency; background : what the frames are drawn over.
    scene : the scene (mesh formats read its layers' images); inputs : files never overwritten.
    extra : format-specific state set by ``prepare`` (a GIF's palette, a sheet's layout).
    staged : files beside the output whose names puppet picks (an atlas, a page image),
        written in full by the sink (never through a link, see
        :func:`puppet.anim.sinks.stage_bytes`) and committed together with the output.
    tolerance : the keyed mesh exports (web player, Spine) keep the frames where
        interpolating between keys would be further than this from puppet's (pixels; 0:
        every frame), see :mod:`puppet.anim.keys`.
    simplify : Spine: pixels; None: the layers' own meshes, else meshes made coarser
        where they draw within this of puppet's (:mod:`puppet.anim.simplify`).
    """

    output: str
    size: tuple[int, int]
    fps: float
    start: float
    count: int
    alpha: bool
    background: Any
    scene: Any
    inputs: tuple = ()
    tmp: str = ""
    extra: dict = field(default_factory=dict)
    staged: list = field(default_factory=list)
    tolerance: float = KEY_TOLERANCE
    simplify: float | None = None


@dataclass(frozen=True)
class Format:
    """One output format.

    Attributes
    ----------
    kind : short name (``--format`` value).
    suffix : path ending that picks it (``"/"``: a folder).
    label : what it is, for help texts and the Export dialog.
    alpha : the output can be see-through (GIF: 1 bit).
    open : ``open(job) -> Sink`` on ``job.tmp``.
    pixels : True: the sink takes RGBA frames; False: solved layers (no drawing).
    also : further suffixes accepted only with ``--format KIND`` (Spine: ``.json``).
    options : which of :data:`OPTIONS` apply (others are refused with one line).
    side : ``side(output) -> [paths]`` written beside the output (checked up front).
    prepare : ``prepare(job, draw)`` before the frames (``draw(i)`` composites frame i).
    """

    kind: str
    suffix: str
    label: str
    alpha: bool
    open: Callable[[Job], Any]
    pixels: bool = True
    also: tuple[str, ...] = ()
    options: frozenset = DRAWN
    side: Callable[[str], list[str]] = lambda output: []
    prepare: Callable[[Job, Callable[[int], Any]], None] | None = None

    @property
    def folder(self) -> bool:
        return self.suffix == "/"


def _file_sink(make):
    """An opener for sinks that write a file object: the file is opened on ``job.tmp``
    and closed with the sink."""
    def open_(job: Job):
        fp = open(job.tmp, "wb")
        try:
            return _Owning(make(fp, job), fp)
        except BaseException:
            fp.close()
            raise
    return open_


class _Owning:
    """A sink that also closes its file object."""

    def __init__(self, sink, fp):
        self.sink, self.fp = sink, fp

    @property
    def frames(self) -> int:
        return self.sink.frames

    @property
    def parallel(self) -> bool:
        return getattr(self.sink, "parallel", False)

    def add(self, item) -> None:
        self.sink.add(item)

    def encode(self, item):
        return self.sink.encode(item)

    def shipper(self):
        return self.sink.shipper()

    def write(self, item) -> None:
        self.sink.write(item)

    def close(self) -> None:
        try:
            self.sink.close()
        finally:
            self.fp.close()

    def abort(self) -> None:
        try:
            self.sink.abort()
        finally:
            self.fp.close()


# The openers below import their sink when a format is used: this table is read by the
# command line's parser, which must not load numpy.
def _dir(job: Job):
    from puppet.anim.sinks import DirSink  # lazy: format registry
    return DirSink(job.tmp)


def _av(name: str):
    def open_(job: Job):
        from puppet.anim import sinks  # lazy: format registry
        return getattr(sinks, f"{name}_sink")(job.tmp, job.size, job.fps)
    return open_


def _gif(fp, job: Job):
    from puppet.anim.sinks import GifSink  # lazy: format registry
    return GifSink(fp, job.size, job.fps, job.extra["palette"], job.alpha)


def _gif_prepare(job: Job, draw) -> None:
    from puppet.anim.sinks import gif_palette  # lazy: format registry
    job.extra["palette"], job.extra["cached"] = gif_palette(draw, job.count, job.alpha)


def _sheet(fp, job: Job):
    from puppet.anim.sinks import SheetSink  # lazy: format registry
    return SheetSink(fp, job.extra["layout"], atlas=(sheet_atlas(job.output), job.output, job.fps, job.inputs),
                     staged=job.staged)


def _sheet_prepare(job: Job, draw) -> None:
    from puppet.anim.sheet import MAX_SIDE, layout  # lazy: format registry

    lay = layout(job.count, *job.size)
    if lay is None:
        w, h = job.size
        raise SceneError(f"-o {job.output!r}: a sprite sheet of {job.count} frames of {w}x{h} does not fit in "
                         f"{MAX_SIDE}x{MAX_SIDE} pixels; lower --fps, shorten it with --from/--to or "
                         "give a smaller --size")
    job.extra["layout"] = lay


def _html(job: Job):
    from puppet.anim.web import HtmlSink  # lazy: format registry
    return HtmlSink(job)


def _spine(job: Job):
    from puppet.anim.spine import SpineSink  # lazy: format registry
    return SpineSink(job)


def _spine_prepare(job: Job, draw) -> None:
    from puppet.anim.spine import check_size  # lazy: format registry
    check_size(job)


def _glb(job: Job):
    from puppet.anim.gltf import GltfSink  # lazy: format registry
    return GltfSink(job)


def _glb_prepare(job: Job, draw) -> None:
    from puppet.anim.gltf import check_count  # lazy: format registry
    check_count(job)


FORMATS: tuple[Format, ...] = (
    Format("gif", ".gif", "GIF", True, _file_sink(_gif), prepare=_gif_prepare),
    Format("mp4", ".mp4", "MP4 (H.264)", False, _av("mp4")),
    Format("webm", ".webm", "WebM (VP9, alpha)", True, _av("webm")),
    Format("apng", ".apng", "APNG (animated PNG)", True, _av("apng")),
    Format("sheet", ".png", "sprite sheet PNG + OUT.json atlas", True, _file_sink(_sheet),
           side=lambda output: [sheet_atlas(output)], prepare=_sheet_prepare),
    Format("dir", "/", "folder of frame_00000.png ...", True, _dir),
    Format("html", ".html", "web player (one self-contained HTML file, WebGL2)", True, _html,
           pixels=False, options=frozenset({"size", "background", "tolerance"})),
    Format("spine", ".spine.json", "Spine 4.2 JSON + .atlas + page PNG (game engines)", True, _spine,
           pixels=False, also=(".json",), options=frozenset({"tolerance", "simplify"}), side=spine_side,
           prepare=_spine_prepare),
    Format("glb", ".glb", "glTF 2.0 binary: a mesh per layer, frames as morph targets", True, _glb,
           pixels=False, options=frozenset(), prepare=_glb_prepare),
)
BY_KIND = {f.kind: f for f in FORMATS}


def suffixes(*, single: bool = False) -> tuple[str, ...]:
    """Every path ending that picks a format by itself (``"/"`` for a folder); with
    ``single``, only formats that write one file or folder and nothing beside it (batch
    jobs: their outputs must not collide, and ``.png`` is a frame there)."""
    return tuple(f.suffix for f in FORMATS if not (single and f.side(f"x{f.suffix}")))


def describe(sep: str = "; ") -> str:
    """``.mp4: MP4 (H.264); ...``: one line for help texts and the Export dialog."""
    return sep.join(f"{'folder/' if f.folder else f.suffix}: {f.label}" for f in FORMATS)


def _by_suffix(path: str) -> Format | None:
    low = path.lower()
    hits = [f for f in FORMATS if not f.folder and low.endswith(f.suffix)]
    return max(hits, key=lambda f: len(f.suffix)) if hits else None  # .spine.json before .json


#: Endings of files puppet does not write: an existing folder named so (``out.gltf/``) is
#: not taken for a frame folder unless the path ends in ``/`` (the user asked for a file).
FILE_ENDINGS = (".gltf", ".json", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff", ".svg", ".pdf",
                ".avi", ".mov", ".mkv", ".m4v", ".ogv", ".zip", ".psd", ".ora", ".kra", ".txt")


def _file_like(path: str) -> bool:
    return os.path.basename(path).lower().endswith(FILE_ENDINGS)


def find(path: str, kind: str | None = None) -> Format:
    """The format of ``path``, or the format named ``kind`` when given (then the path
    must end in its suffix or one of its ``also`` suffixes).

    The path's form decides, never what happens to exist there: a known ending picks its
    format (an existing folder at ``out.html`` stays an HTML output, which the output
    checker then refuses as a folder, rather than being filled with frames); a frame
    folder is a path ending in ``/``, or an existing folder whose name has no known
    ending and no ending of a file puppet does not write (:data:`FILE_ENDINGS`: an existing
    folder ``out.gltf`` is refused like the path ``out.gltf``); ``--format dir`` names one
    explicitly.

    Raises
    ------
    SceneError
        One line naming the path and the endings accepted.
    """
    slash = path.endswith(("/", os.sep))
    if kind is not None:
        fmt = BY_KIND.get(kind)
        if fmt is None:
            raise SceneError(f"--format {kind!r}: choose one of {', '.join(BY_KIND)}")
        if fmt.folder:
            ok = slash or os.path.isdir(path)
        else:
            ok = not slash and path.lower().endswith((fmt.suffix, *fmt.also))
        if not ok:
            ends = " or ".join(("a folder (ending in /)",) if fmt.folder else (fmt.suffix, *fmt.also))
            raise SceneError(f"-o {path!r}: --format {kind} writes {ends}")
        return fmt
    if slash:
        return BY_KIND["dir"]
    fmt = _by_suffix(path)
    if fmt is None and os.path.isdir(path) and not _file_like(path):
        return BY_KIND["dir"]
    if fmt is None:
        ends = ", ".join(f.suffix for f in FORMATS if not f.folder)
        raise SceneError(f"-o {path!r}: give a folder (ending in /) or a file ending in {ends} "
                         "(.json with --format spine)")
    return fmt


def check_options(fmt: Format, *, size=None, wireframe=False, background=None, tolerance=None,
                  simplify=None) -> None:
    """Refuse an option the format cannot honour (one line naming it)."""
    asked = {"size": size is not None, "wireframe": bool(wireframe), "background": background is not None,
             "tolerance": tolerance is not None, "simplify": simplify is not None}
    for name in OPTIONS:
        if not asked[name] or name in fmt.options:
            continue
        if name in DRAWN:
            raise SceneError(f"--{name} does not apply to {fmt.label}: it writes meshes and textures, "
                             "not drawn frames")
        takers = [f".{f.kind}" if f.kind != "spine" else "Spine" for f in FORMATS if name in f.options]
        raise SceneError(f"--{name} does not apply to {fmt.label}: only {' and '.join(takers)} "
                         f"{'take' if len(takers) > 1 else 'takes'} it")
