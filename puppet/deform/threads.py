"""One BLAS thread inside the solvers.

The deformers' dense products are skinny (``W^T M`` with ``W (k, n)``, k the number of
controls): OpenBLAS splits them over every core and, on a 2-core machine that is busy
with anything else (a second solver thread, the renderer, another process), its spinning
threads oversubscribe the cores. Measured here with the machine busy: ``W^T M`` at 20k
vertices 8.0 ms with 2 threads against 0.13 ms with one, a 20k-vertex ARAP pose
160-190 ms against 110-130 ms, image-space MLS on 512x512 points 245 ms against 69 ms.
So every solve entry point runs under :func:`one_blas_thread` (decorator
:func:`blas_capped`): the outermost call caps the BLAS pools at ``BLAS_THREADS`` and
restores them when it returns (about 20 us per outermost call, nested calls cost a
counter). The rest of the process keeps its own setting: nothing is changed globally.
"""
from __future__ import annotations

import functools
import os
import sys
import threading
from contextlib import contextmanager

__all__ = ["BLAS_THREADS", "one_blas_thread", "blas_capped"]

#: BLAS threads inside a solve; ``None`` leaves the pools alone.
BLAS_THREADS: int | None = 1

_lock = threading.Lock()
_depth = 0
_limiter = None
_controller = None
_modules = 0  # len(sys.modules) when the controller looked for pools


def _limit():
    """Cap the BLAS pools; returns the limiter that restores them (or None).

    The pools are looked up again (about 1 ms) only when modules were imported since the
    last look, as an import may load another BLAS (SciPy's own, for instance)."""
    global _controller, _modules
    if (BLAS_THREADS == 1 and os.environ.get("PUPPET_BLAS_SET_AT_START") == "1"
            and os.environ.get("OPENBLAS_NUM_THREADS") == "1"):
        return None  # the `puppet` command set one BLAS thread before numpy loaded
    try:
        if _controller is None or len(sys.modules) != _modules:
            from threadpoolctl import ThreadpoolController

            _controller = ThreadpoolController()
            _modules = len(sys.modules)
        return _controller.limit(limits=BLAS_THREADS, user_api="blas")
    except Exception:  # threadpoolctl missing or a pool it cannot drive: run as is
        return None


@contextmanager
def one_blas_thread():
    """Run the block with ``BLAS_THREADS`` BLAS threads (re-entrant, thread-safe)."""
    global _depth, _limiter
    if BLAS_THREADS is None:
        yield
        return
    with _lock:
        if _depth == 0:
            _limiter = _limit()
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0 and _limiter is not None:
                _limiter.restore_original_limits()
                _limiter = None


def blas_capped(fn):
    """Decorator: ``fn`` runs under :func:`one_blas_thread`."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with one_blas_thread():
            return fn(*args, **kwargs)
    return wrapper
