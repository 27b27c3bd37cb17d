"""Adjustment layers of a PSD baked into the layers below them, with psd-tools' own
adjustment functions (brightness/contrast, levels, curves, exposure, hue/saturation,
invert, posterize, threshold).

An adjustment changes the composite of what lies below it (in its group when the group
is isolated, in the whole document under pass-through groups). A puppet moves its parts
apart, so the adjustment is applied to each of those layers' colours instead:
``C' = C + a m (f(C) - C)`` with ``f`` the adjustment, ``a`` its opacity (and, for a
layer below a pass-through group that holds the adjustment, the group's share, see
:meth:`puppet.imaging.layered.psd._Reader.adjust`) and ``m`` its mask. That equals the
file where a layer is opaque and in front (the composite there is that layer's colour);
at soft edges over other layers it differs a little.
"""
from __future__ import annotations

import numpy as np

from puppet.imaging.layered.art import ArtLayer, apply_mask, to_uint8


def adjustment_function(layer):
    """psd-tools' function for the adjustment layer (None when it has none, or no data)."""
    from psd_tools.composite.adjustments import ADJUSTMENT_FUNC

    fn = ADJUSTMENT_FUNC.get(layer.kind)
    return fn if fn is not None and getattr(layer, "_data", None) is not None else None


def bake_adjustment(layer, fn, targets: list[ArtLayer], mask: tuple = (), strength=None) -> int:
    """Apply the adjustment ``layer`` (psd-tools' ``fn``) to ``targets`` in place; ``mask``
    as :func:`puppet.imaging.layered.psd._mask` gives it; ``strength``: per target, a factor
    (0..1) of its effect there, a number or (h, w, 1) per pixel (None: 1 each). Returns
    how many layers changed."""
    from psd_tools.constants import ColorMode

    changed = 0
    for lay, k in zip(targets, [1.0] * len(targets) if strength is None else strength):
        if not lay.visible:  # a hidden layer is not in the file's composite
            continue
        colour = lay.rgba[..., :3].astype(np.float32) / 255.0
        out = np.asarray(fn(colour, ColorMode.RGB, layer), np.float32)
        weight = np.full(lay.rgba.shape[:2] + (1,), 255, np.uint8)
        for m in mask:
            weight4 = np.concatenate([np.zeros(weight.shape[:2] + (3,), np.uint8), weight], axis=2)
            apply_mask(weight4, lay.offset, *m)
            weight = weight4[..., 3:]
        a = weight.astype(np.float32) / 255.0 * np.float32(layer.opacity / 255.0) * np.asarray(k, np.float32)
        new = to_uint8(colour + a * (out[..., :3] - colour))
        if not np.array_equal(new, lay.rgba[..., :3]):
            lay.rgba[..., :3] = new
            changed += 1
    return changed
