"""The scene document: plain dataclasses, as validated from the scene format (v1)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MASK_KINDS = ("alpha", "threshold", "polygon", "rect", "file", "grabcut")
INPAINT_METHODS = ("none", "pyramid", "telea", "ns", "fsr", "outline")
METHODS = ("arap", "igarashi", "mls", "mls-skeleton")
WEIGHTS = ("cotangent", "cotangent-raw", "uniform")
INITS = ("mls", "rest")
MODES = ("rigid", "similar", "distort")
#: ``deformer.accelerate``: "none" (a fixed number of plain ARAP iterations, as always) or
#: "anderson" (Anderson-accelerated iterations until ``deformer.tolerance``)
ACCELERATIONS = ("none", "anderson")
#: ``deformer.iterations`` of an accelerated solve when the file does not say: the most it
#: may take (it stops at the tolerance, in about 30 from the MLS guess at every size measured)
ACCELERATED_ITERATIONS = 300
PIN_KINDS = ("interior", "exterior", "starch")
EASES = ("linear", "smooth", "step", "bezier")
INBETWEENS = ("rigid", "linear")
DEPTH_MODES = ("step", "interpolate")


@dataclass
class MeshOptions:
    """Per-layer meshing density; ``None`` means chosen from the layer size."""

    max_area: float | None = None
    min_angle: float = 25.0
    simplify: float = 1.0


@dataclass
class Mask:
    """How a layer's pixels are chosen: ``kind`` in MASK_KINDS and its parameters."""

    kind: str
    threshold: float = 250.0
    invert: bool = False
    polygon: np.ndarray | None = None  # (p, 2) canvas coordinates
    rect: tuple[float, float, float, float] | None = None
    file: str | None = None  # absolute path
    explicit: bool = True  # False when the default was chosen for the user


@dataclass
class Exterior:
    auto: bool = True
    beta: float = 1.0


#: ``layers[i].cage.coordinates``, the default first (puppet.deform.cage.KINDS)
CAGE_KINDS = ("green", "mvc", "harmonic")


@dataclass
class Cage:
    """A layer's cage: ``points`` (m, 2) canvas coordinates, or None where the cage is made
    from the layer's mask when the scene is built (``auto`` vertices, ``offset`` px out);
    a saved automatic cage has both. ``coordinates`` in CAGE_KINDS."""

    points: np.ndarray | None
    auto: int | None = None
    offset: float = 10.0
    coordinates: str = "green"


@dataclass
class Layer:
    name: str
    image: str | None  # absolute path of the layer's own image, None = pixels of source
    offset: tuple[float, float] = (0.0, 0.0)
    mask: Mask | None = None  # None = default from the image (alpha or threshold 250)
    order: float | None = None
    inpaint: str = "none"
    mesh: MeshOptions = field(default_factory=MeshOptions)
    exterior: Exterior | None = None
    index: int = 0  # position in the scene's list
    mode: str | None = None  # ``deformer.mode`` of this layer (None: the scene's)
    stiffness: str | None = None  # absolute path of the painted stiffness image
    visible: bool = True  # False: built and posed (links, pins), never drawn
    cage: Cage | None = None  # a caged layer is deformed by its cage, not by ARAP


@dataclass
class Link:
    layers: tuple[str, str]
    segments: list[np.ndarray]  # each (2, 2): [[x0, y0], [x1, y1]]
    points: list[np.ndarray] = field(default_factory=list)  # hinges, each (2,)
    polygons: list[np.ndarray] = field(default_factory=list)  # shared patches, each (p, 2)
    strength: float = 1.0  # coupling across the link, 0..1


@dataclass
class Pin:
    name: str
    layer: str
    at: np.ndarray  # (2,)
    depth: float = 0.0
    kind: str = "interior"
    radius: float | None = None  # starch pins: reach of the stiffening, px


@dataclass
class Deformer:
    method: str = "arap"
    weights: str = "cotangent"
    init: str = "mls"
    iterations: int = 20
    alpha: float = 1.0
    relax_foldovers: bool = True
    mode: str = "rigid"
    accelerate: str = "none"  # "anderson": iterate to ``tolerance`` (``iterations`` is then the most)
    tolerance: float = 0.01  # px: largest vertex step of a plain iteration that ends an accelerated solve


@dataclass
class Target:
    """Where a pose puts one pin; ``None`` fields keep the pin's rest value."""

    to: np.ndarray | None = None
    angle: float = 0.0
    depth: float | None = None


@dataclass
class Key:
    """One animation key: a named pose (every pin) or its own pin targets (``pins``,
    only the pins it names). ``ease`` shapes the segment that ends at this key;
    ``curve`` is the ``bezier`` ease's ``(cx1, cy1, cx2, cy2)``. A pose key's
    ``overrides`` replace the pose's target of the pins they name (a Target), or leave a
    pin out of the key (None)."""

    time: float
    pose: str | None = None
    ease: str = "linear"
    pins: dict[str, Target] | None = None
    curve: tuple[float, float, float, float] | None = None
    overrides: dict[str, Target | None] | None = None


@dataclass
class Animation:
    """``inbetween``: ``"rigid"`` (shape-preserving mesh interpolation) or ``"linear"``
    (pin targets on straight lines, each frame solved); ``depth``: pin depth ``"step"``s
    at the keys or ``"interpolate"``s."""

    fps: float
    keys: list[Key]
    inbetween: str = "rigid"
    depth: str = "step"


@dataclass(frozen=True)
class Chain:
    """A chain of pins with secondary motion (``physics.chains[i]``): the first follows the
    animation, each later one its animated place through a damped spring."""

    pins: tuple[str, ...]
    frequency: float = 2.0  # natural frequency, Hz
    damping: float = 0.3  # damping ratio (1: critical)
    gravity: float = 0.0  # px/s^2 along +y


@dataclass
class SceneData:
    """Everything a scene file says, validated; paths are absolute."""

    file: str
    canvas: tuple[int, int] | None
    background: tuple[int, int, int, int] | str
    source: str | None
    layers: list[Layer]
    links: list[Link] = field(default_factory=list)
    pins: list[Pin] = field(default_factory=list)
    bones: list[tuple[str, str]] = field(default_factory=list)
    deformer: Deformer = field(default_factory=Deformer)
    poses: dict[str, dict[str, Target]] = field(default_factory=dict)
    animation: Animation | None = None
    raw: dict = field(default_factory=dict)  # the JSON as read, for saving
    video: dict | None = None  # a video scene: {"start", "fps", "size", "count"} (puppet.scene.format.video)
    chains: list[Chain] = field(default_factory=list)  # physics.chains: secondary motion
    garment: dict | None = None  # {"category", "order", "name"?} (puppet.scene.format.garment)
