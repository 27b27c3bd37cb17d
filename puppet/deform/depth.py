"""Per-vertex depth interpolated from pin depths (Shepard / inverse-distance weights).

The drawn depth of a vertex is its layer's stacking index plus this field. The weights
are the same inverse (geodesic) distance weights the object-space MLS uses, so a pin's
depth spreads over the region that the pin also moves.
"""
from __future__ import annotations

import numpy as np

from puppet.deform.mls import DistanceWeights, distance_weights
from puppet.deform.threads import blas_capped

__all__ = ["depth_field"]


@blas_capped
def depth_field(D: np.ndarray, pin_depth, *, alpha: float = 1.0,
                weights: DistanceWeights | None = None) -> np.ndarray:
    """Weighted average of pin depths with weights ``D^(-2 alpha)``.

    Parameters
    ----------
    D : (k, n) float
        Distance (typically geodesic) from each of the k pins to each of the n
        vertices; ``inf`` where unreachable.
    pin_depth : (k,) float
        Depth of each pin, in stacking units.
    alpha : float
        Weight exponent.
    weights : DistanceWeights, optional
        ``puppet.deform.mls.distance_weights(D, alpha=alpha)`` computed before (they do
        not depend on the pin depths); None: computed here.

    Returns
    -------
    z : (n,) float
        ``z[v] = sum_i w_i(v) pin_depth[i] / sum_i w_i(v)``; exactly ``pin_depth[i]``
        where ``D[i, v] == 0``; ``0`` where no pin is reachable (and everywhere when
        ``k == 0``). Always within ``[min(pin_depth), max(pin_depth)]`` where reachable.
    """
    D = np.asarray(D, dtype=np.float64)
    z_pin = np.asarray(pin_depth, dtype=np.float64).reshape(-1)
    if D.ndim != 2 or D.shape[0] != len(z_pin):
        raise ValueError(f"D must have shape (k, n) with k = {len(z_pin)}, got {D.shape}")
    n = D.shape[1]
    if not z_pin.any():  # no pins, or all at depth 0 (the common case): no weights needed
        return np.zeros(n)
    w = distance_weights(D, alpha=alpha) if weights is None else weights
    if w.todo.shape != (n,):
        raise ValueError(f"weights are for {w.todo.shape[0]} points, not {n}")
    z = np.zeros(n)
    todo, Wt = w.todo, w.W
    z[todo] = (z_pin @ Wt) / Wt.sum(axis=0)
    hit = w.exact >= 0
    z[hit] = z_pin[w.exact[hit]]
    # a convex combination can leave [min, max] by one rounding; clamp it back
    z[todo] = np.clip(z[todo], z_pin.min(), z_pin.max())
    return z
