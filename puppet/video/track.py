"""Track a skeleton's joints through a cartoon clip with SIFT key points (Shen et al. 2010, §4).

Each frame's SIFT key points are matched (ratio test) to those of the previous good frame and
to those of the reference frame (the first frame, or the last frame the user re-anchored);
repeated RANSAC similarity fits keep the matches that move with some rigid part. A joint is
carried by the affine map of the key-point triangle containing it (eq. 17-19), or by a local
similarity of its nearest matches where it lies outside the triangulation, or, with no usable
matches around it, by dense optical flow (DIS) sampled at the joint. The reference estimate has
no drift and wins whenever it has enough support near the joint; the frame-to-frame estimate
takes over where the reference frame's look is lost (occlusion, a limb turned far away).

A frame with too few matches, or where a joint would leave the picture, is *lost*: the skeleton
is held at its last good value and the frame reported.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from puppet.video.carry import PairMap
from puppet.video.features import Detector, match, motion_groups
from puppet.video.refine import patch_radius, refine

Point = tuple[float, float]


@dataclass
class TrackStep:
    """The tracker's answer for one frame.

    Attributes
    ----------
    joints : dict of str to (x, y)
        Positions on this frame (the last good ones when ``lost``).
    confidence : dict of str to float
        0..1 per joint (0 on a lost frame).
    lost : bool
        Tracking failed on this frame and the skeleton is held.
    reason : str
        Why it was lost, ``""`` otherwise.
    """

    joints: dict[str, Point]
    confidence: dict[str, float]
    lost: bool = False
    reason: str = ""


@dataclass
class Tracks:
    """Tracked joints of a whole clip.

    Attributes
    ----------
    joints : dict of str to (n, 2) float array
        Per frame positions, NaN on lost frames (see :meth:`held` for the held skeleton).
    confidence : dict of str to (n,) float array
    lost_frames : list of int
    reasons : dict of int to str
        Why each lost frame was lost.
    """

    joints: dict[str, np.ndarray]
    confidence: dict[str, np.ndarray]
    lost_frames: list[int] = field(default_factory=list)
    reasons: dict[int, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(next(iter(self.confidence.values()))) if self.confidence else 0

    def held(self) -> dict[str, np.ndarray]:
        """Positions with each lost frame holding the last good skeleton ((n, 2) per joint)."""
        out = {}
        for name, xy in self.joints.items():
            xy = xy.copy()
            for i in range(1, len(xy)):
                if np.isnan(xy[i, 0]):
                    xy[i] = xy[i - 1]
            out[name] = xy
        return out

    def to_json(self, fps: float, size: tuple[int, int]) -> dict:
        """The ``--tracks`` form: ``{"fps", "size": [W, H], "joints": {pin: [[x, y] | null]}, "confidence"}``."""
        joints = {n: [None if np.isnan(p[0]) else [round(float(p[0]), 3), round(float(p[1]), 3)] for p in xy]
                  for n, xy in self.joints.items()}
        conf = {n: [round(float(c), 4) for c in cs] for n, cs in self.confidence.items()}
        return {"fps": fps, "size": [int(size[0]), int(size[1])], "joints": joints, "confidence": conf}


def _gray(frame: np.ndarray) -> np.ndarray:
    import cv2

    frame = np.asarray(frame)
    if frame.ndim == 2:
        return np.ascontiguousarray(frame, np.uint8)
    code = cv2.COLOR_RGBA2GRAY if frame.shape[2] == 4 else cv2.COLOR_RGB2GRAY
    return cv2.cvtColor(np.ascontiguousarray(frame[..., : frame.shape[2]], np.uint8), code)


@dataclass
class _Frame:
    feats: object  # Features
    gray: np.ndarray
    joints: np.ndarray  # (k, 2) joint positions on this frame


class Tracker:
    """Carry named joints from a first frame through the frames that follow.

    Parameters
    ----------
    first : (H, W, 3) uint8 array
        The RGB frame the joints are placed on.
    joints : dict of str to (x, y)
        Joint positions on ``first`` in pixels.
    mask : (H, W) bool array, optional
        Foreground of ``first``; key points outside it are ignored.
    min_matches : int
        A frame with fewer RANSAC-inlier matches (to both the previous and the reference frame)
        is lost.
    detect_scale : float, optional
        SIFT runs on the frame resized by this factor (see :class:`puppet.video.features.Detector`);
        by default ``min(1, 240 / shorter side)``: 0.5 at 640x480, which keeps sub-pixel key points
        (SIFT doubles its input) at a quarter of the cost.
    contrast : float
        SIFT contrast threshold.
    ratio : float
        Lowe's ratio test threshold.
    align : bool
        Align each carried joint on the picture (ECC, :mod:`puppet.video.refine`); ``False``
        keeps the key-point carrying alone (the paper's method, for comparison).
    patch : int, optional
        Half size in pixels of the neighbourhood aligned by ECC (:mod:`puppet.video.refine`);
        by default chosen per joint on the reference frame: the smallest of 12, 16, 24, 32, 48 px
        (at 640x480; in proportion to the frame diagonal) with edges in two directions.
    """

    def __init__(self, first: np.ndarray, joints: dict[str, Point], *, mask: np.ndarray | None = None,
                 min_matches: int = 8, detect_scale: float | None = None, contrast: float = 0.02, ratio: float = 0.8,
                 align: bool = True, patch: int | None = None):
        self.names = list(joints)
        self.min_matches = int(min_matches)
        self.ratio = float(ratio)
        if detect_scale is None:
            detect_scale = min(1.0, 240.0 / min(np.shape(first)[:2]))
        self._det = Detector(scale=detect_scale, contrast=contrast)
        self._dis = None
        self.patch = int(patch) if patch else None
        self.align = bool(align)
        self._held = np.array([joints[n] for n in self.names], np.float64).reshape(-1, 2)
        self.reanchor(first, joints, mask)

    # -- public -------------------------------------------------------------------------------
    @property
    def held(self) -> np.ndarray:
        """Where the joints are now, in :attr:`names` order ((k, 2) canvas xy, a copy)."""
        return self._held.copy()

    def reanchor(self, frame: np.ndarray, joints: dict[str, Point], mask: np.ndarray | None = None) -> None:
        """Make ``frame`` the new reference with the skeleton the user placed on it.

        Joints missing from ``joints`` are first tracked onto ``frame`` (held if that fails);
        unknown names raise ``KeyError``.
        """
        unknown = set(joints) - set(self.names)
        if unknown:
            raise KeyError(f"unknown joint(s): {', '.join(sorted(unknown))}")
        if hasattr(self, "_ref") and set(joints) != set(self.names):
            self.step(frame, mask=mask)
        P = self._held.copy()
        for i, n in enumerate(self.names):
            if n in joints:
                P[i] = joints[n]
        gray = _gray(frame)
        self.size = (gray.shape[1], gray.shape[0])
        self._ref = _Frame(self._det(gray, mask), gray, P)
        self._radii = np.array([self._radius(gray, p) for p in P], int)
        self._prev = self._ref
        self._held = P.copy()
        self._aff = np.tile(np.hstack([np.eye(2), np.zeros((2, 1))]), (len(P), 1, 1))

    def step(self, frame: np.ndarray, *, mask: np.ndarray | None = None) -> TrackStep:
        """Track the joints onto the next frame ((H, W, 3) uint8, same size as the first)."""
        gray = _gray(frame)
        cur = self._det(gray, mask)
        ref_map = self._pair(self._ref.feats, cur)
        prev_map = ref_map if self._prev is self._ref else self._pair(self._prev.feats, cur)
        best = max(len(ref_map), len(prev_map))
        if best < self.min_matches:
            return self._lost(f"too few matches ({best} < {self.min_matches})")
        new = np.empty_like(self._held)
        conf = np.empty(len(self.names))
        affs = np.empty_like(self._aff)
        flow = None
        for j in range(len(self.names)):
            a = ref_map.carry(self._ref.joints[j]) if len(ref_map) >= self.min_matches else None
            b = prev_map.carry(self._prev.joints[j]) if len(prev_map) >= self.min_matches else None
            if b is not None:  # its map from the reference frame, through the previous one
                b.affine = _compose(b.affine, self._aff[j])
            pick = self._best(j, a, b, gray)
            if pick is None:
                if flow is None:
                    flow = self._flow(self._prev.gray, gray)
                d = _sample(flow, self._prev.joints[j])
                new[j], conf[j] = self._prev.joints[j] + d, 0.25
                affs[j] = self._aff[j] + np.hstack([np.zeros((2, 2)), d[:, None]])
            else:
                new[j], conf[j], affs[j] = pick
        w, h = self.size
        out = [n for n, p in zip(self.names, new) if not (-0.5 <= p[0] <= w - 0.5 and -0.5 <= p[1] <= h - 0.5)]
        self._prev = _Frame(cur, gray, new)
        self._aff = affs
        if out:
            return self._lost(f"joint(s) left the frame: {', '.join(out)}")
        self._held = new.copy()
        return TrackStep(self._as_dict(new), {n: float(c) for n, c in zip(self.names, conf)})

    # -- helpers ------------------------------------------------------------------------------
    def _best(self, j: int, a, b, gray: np.ndarray, *, gate: float = 4.0,
              tie: float = 0.02):
        """Refine the reference-frame estimate ``a`` and the previous-frame one ``b`` (Carried or
        None) against the joint's neighbourhood on the reference frame.

        When they agree (within ``gate`` pixels) ``a`` is aligned (no drift), ``b`` only if that
        fails; when they disagree, both, and ``a`` replaces ``b`` (which carries the joint's own turn from the
        previous frame) only with a correlation (ECC's plus that of the surroundings,
        :attr:`puppet.video.refine.Refined.context`) higher by ``tie`` (continuity: a look-alike
        part elsewhere can align well too). With neither aligned, a wider correlation search
        around them; failing that, the carried position.
        Returns ``(xy, confidence, affine)`` or None when both are None.
        """
        cands = [c for c in (a, b) if c is not None]
        if not cands:
            return None
        if not self.align:
            c = a if a is not None and (b is None or a.support >= 3) else b
            return c.xy, _confidence(c), c.affine
        far = len(cands) == 2 and np.hypot(*(a.xy - b.xy)) > gate
        if far:
            cands = [b, a]
        best = None
        for c in cands:
            r = refine(self._ref.gray, self._ref.joints[j], gray, c.affine, r=self._radii[j], with_context=far)
            if r.ok and (best is None or r.rho + r.context > best.rho + best.context + tie):
                best = r
            if best is not None and not far:
                break
        if best is None:
            for c in cands:
                r = refine(self._ref.gray, self._ref.joints[j], gray, c.affine, r=self._radii[j],
                           wide=2 * self._radii[j], with_context=False)
                if r.ok:
                    best = r
                    break
        if best is not None:
            return best.xy, 0.5 + 0.5 * float(np.clip((best.rho - 0.8) / 0.2, 0, 1)), best.affine
        if a is not None:
            return a.xy, 0.7 * _confidence(a), a.affine
        return b.xy, 0.5 * _confidence(b), b.affine

    def _radius(self, gray: np.ndarray, p: np.ndarray) -> int:
        if self.patch:
            return self.patch
        f = float(np.hypot(*gray.shape)) / 800.0
        return patch_radius(gray, p, sorted({max(10, int(round(f * r))) for r in (12, 16, 24, 32, 48)}))

    def _lost(self, reason: str) -> TrackStep:
        return TrackStep(self._as_dict(self._held), {n: 0.0 for n in self.names}, True, reason)

    def _as_dict(self, P: np.ndarray) -> dict[str, Point]:
        return {n: (float(p[0]), float(p[1])) for n, p in zip(self.names, P)}

    def _pair(self, a, b):
        ia, ib = match(a, b, ratio=self.ratio)
        src, dst = a.pts[ia], b.pts[ib]
        groups = motion_groups(src, dst)
        keep = groups >= 0
        radius = 0.1 * float(np.hypot(*self.size))
        return PairMap(src[keep], dst[keep], groups[keep], radius=radius)

    def _flow(self, g0: np.ndarray, g1: np.ndarray) -> np.ndarray:
        import cv2

        if self._dis is None:
            self._dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_FAST)
        return self._dis.calc(g0, g1, None)


def _compose(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A o B`` for (2, 3) affine maps."""
    return np.hstack([A[:, :2] @ B[:, :2], (A[:, :2] @ B[:, 2] + A[:, 2])[:, None]])


def _confidence(c) -> float:
    """From the number of supporting matches near the joint and the local fit's residual."""
    return min(1.0, c.support / 4.0) / (1.0 + (c.resid / 2.0) ** 2)


def _sample(flow: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Flow ((H, W, 2)) at point ``p`` (bilinear, clamped to the frame)."""
    h, w = flow.shape[:2]
    x = float(np.clip(p[0], 0, w - 1))
    y = float(np.clip(p[1], 0, h - 1))
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    fx, fy = x - x0, y - y0
    top = flow[y0, x0] * (1 - fx) + flow[y0, x1] * fx
    bot = flow[y1, x0] * (1 - fx) + flow[y1, x1] * fx
    return top * (1 - fy) + bot * fy


def track(frames: Iterable[np.ndarray], joints: dict[str, Point], *, masks: Iterable | None = None,
          anchors: dict[int, dict[str, Point]] | None = None, **options) -> Tracks:
    """Run a :class:`Tracker` over ``frames`` (each (H, W, 3) uint8), the first holding ``joints``.

    Parameters
    ----------
    masks : iterable of (H, W) bool arrays or None, optional
        Foreground per frame, aligned with ``frames``.
    anchors : dict of int to dict of str to (x, y), optional
        Frames where the user re-placed the skeleton: the tracker re-anchors there.
    **options
        Passed to :class:`Tracker`.

    Returns
    -------
    Tracks
    """
    anchors = dict(anchors or {})
    mask_iter = iter(masks) if masks is not None else None
    names = list(joints)
    xs: list[np.ndarray] = []
    cs: list[np.ndarray] = []
    lost, reasons = [], {}
    tracker = None
    for i, frame in enumerate(frames):
        mask = next(mask_iter) if mask_iter is not None else None
        if tracker is None:
            start = {**joints, **anchors.get(0, {})}
            tracker = Tracker(frame, start, mask=mask, **options)
            xs.append(np.array([start[n] for n in names], float))
            cs.append(np.ones(len(names)))
            continue
        if i in anchors:
            tracker.reanchor(frame, anchors[i], mask)
            xs.append(tracker.held)
            cs.append(np.array([1.0 if n in anchors[i] else 0.5 for n in names]))
            continue
        st = tracker.step(frame, mask=mask)
        if st.lost:
            lost.append(i)
            reasons[i] = st.reason
            xs.append(np.full((len(names), 2), np.nan))
        else:
            xs.append(np.array([st.joints[n] for n in names], float))
        cs.append(np.array([st.confidence[n] for n in names]))
    X = np.array(xs).reshape(-1, len(names), 2)
    C = np.array(cs).reshape(-1, len(names))
    return Tracks({n: X[:, j] for j, n in enumerate(names)}, {n: C[:, j] for j, n in enumerate(names)},
                  lost, reasons)
