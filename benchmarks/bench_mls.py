"""mls_deform (rigid, image space) over a 512x512 grid with 10 control points, against a
plain vectorised numpy implementation of Schaefer et al.'s rigid MLS written here as the
baseline. Prints a table; the issue's target is puppet <= 0.35x the baseline."""
from __future__ import annotations

import time

import numpy as np

from puppet.deform.mls import mls_deform


def baseline_rigid(X, p, q, alpha=1.0):
    """Textbook vectorised rigid MLS: (k, n) arrays, no tricks."""
    d2 = ((p[:, None, :] - X[None, :, :]) ** 2).sum(-1)              # (k, n)
    w = 1.0 / np.maximum(d2, 1e-300) ** alpha
    ws = w.sum(0)
    ps = (w[..., None] * p[:, None, :]).sum(0) / ws[:, None]           # (n, 2)
    qs = (w[..., None] * q[:, None, :]).sum(0) / ws[:, None]
    ph = p[:, None, :] - ps[None]                                      # (k, n, 2)
    qh = q[:, None, :] - qs[None]
    a = (w * (ph[..., 0] * qh[..., 0] + ph[..., 1] * qh[..., 1])).sum(0)
    b = (w * (ph[..., 0] * qh[..., 1] - ph[..., 1] * qh[..., 0])).sum(0)
    r = np.hypot(a, b)
    c, s = a / r, b / r
    v = X - ps
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], 1) + qs


def best(f, reps=5):
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        out = f()
        ts.append(time.perf_counter() - t)
    return min(ts) * 1e3, out


def main():
    rng = np.random.default_rng(0)
    ys, xs = np.mgrid[0:512, 0:512]
    X = np.stack([xs.ravel(), ys.ravel()], 1).astype(np.float64) + 0.5
    p = rng.uniform(0, 512, (10, 2))
    q = p + rng.normal(0, 25, (10, 2))
    tb, Ub = best(lambda: baseline_rigid(X, p, q))
    tp, Up = best(lambda: mls_deform(X, p, q, kind="rigid"))
    import puppet.deform.mls as mls
    t1, _ = best(lambda: mls._mls_image_chunk(X, p, q, "rigid", 1.0))
    print("rigid MLS, 512x512 grid (262144 points), 10 control points; ms, best of 5")
    print(f"{'implementation':28s} {'ms':>9s}")
    print(f"{'plain vectorised numpy':28s} {tb:9.1f}")
    print(f"{'puppet mls_deform':28s} {tp:9.1f}")
    print(f"{'puppet, one block (no chunks)':28s} {t1:9.1f}   ({t1 / tb:.2f}x)")
    ratio = tp / tb
    print(f"ratio puppet/baseline {ratio:.2f}x   target <= 0.35x   {'PASS' if ratio <= 0.35 else 'MISS'}")
    print(f"max |difference| {np.abs(Ub - Up).max():.2e} px")


if __name__ == "__main__":
    main()
