"""Sparse factorisations of the ARAP-family systems, and their solves.

One factorisation per mesh and pin set (``FACTORIZATIONS`` counts them: a drag must not
add any). QDLDL (sparse LDL^T with AMD ordering) is the default: it factorises 2.5x
faster than CHOLMOD (cholespy) at 5k-20k vertices and releases the GIL, so the factor is
built on a second thread while ``arap_precompute`` computes geodesic distances, and the
two coordinates are solved on two threads above ``PARALLEL_MIN_FREE`` free vertices.
cholespy and SciPy's SuperLU are the alternatives; SuperLU is the fallback.
"""
from __future__ import annotations

import queue
import threading

import numpy as np
import scipy.sparse as sp

#: Number of sparse factorisations done by this module (a drag must not add any).
FACTORIZATIONS = 0

SOLVERS = ("qdldl", "cholespy", "splu")

#: Use a second thread: for the factorisation while ``arap_precompute`` builds the rest,
#: and for the second coordinate's solve in ``arap_solve`` (QDLDL, from
#: ``PARALLEL_MIN_FREE`` free vertices on). Results are bitwise the same either way.
THREADS = True

#: Crossover of the per-iteration thread hand-off against one QDLDL solve (2 cores).
PARALLEL_MIN_FREE = 4000
#: Fewer iterations than this (a drag preview's few warm-started ones) stay on one thread:
#: starting the second one costs more than it saves, most of all while a GL rasteriser's
#: threads share the 2 cores (T-rex preview, 4 iterations: median 6.4 ms against 7.4 ms,
#: p95 7.5 ms against 13-18 ms).
PARALLEL_MIN_ITERATIONS = 8


class _QdldlFactor:
    """LDL^T factor by QDLDL (AMD ordering) via the qdldl wheel; releases the GIL."""

    kind = "qdldl"

    def __init__(self, A: sp.spmatrix):
        import qdldl

        self.n = A.shape[0]
        try:
            self._solver = qdldl.Solver(_upper_csc(A), upper=True)
        except TypeError:  # older qdldl wheels: no `upper`, they take the triangle themselves
            self._solver = qdldl.Solver(sp.csc_matrix(A))

    def solve1(self, b: np.ndarray) -> np.ndarray:
        """One right-hand side (n,); safe to call from two threads at once."""
        return self._solver.solve(b)

    def solve(self, B: np.ndarray) -> np.ndarray:
        B = np.asarray(B, dtype=np.float64)
        if B.ndim == 1:
            return self._solver.solve(B)
        return np.stack([self._solver.solve(B[:, c]) for c in range(B.shape[1])], axis=1)


class _CholespyFactor:
    """CHOLMOD (supernodal, AMD/METIS ordering) Cholesky factor via cholespy."""

    kind = "cholespy"

    def __init__(self, A: sp.csc_matrix):
        import cholespy

        A = sp.csc_matrix(A)
        self.n = A.shape[0]
        self._solver = cholespy.CholeskySolverD(
            self.n, A.indptr.astype(np.int32), A.indices.astype(np.int32),
            A.data.astype(np.float64), cholespy.MatrixType.CSC)

    def solve(self, B: np.ndarray) -> np.ndarray:
        B = np.ascontiguousarray(B, dtype=np.float64)
        X = np.empty_like(B)
        self._solver.solve(B, X)
        return X


class _SpluFactor:
    """SuperLU factor (scipy), symmetric mode with a minimum-degree ordering on A+A^T."""

    kind = "splu"

    def __init__(self, A: sp.csc_matrix):
        self.n = A.shape[0]
        import scipy.sparse.linalg as spla  # lazy: the fallback only; 0.1 s of every command's start-up

        self._lu = spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A",
                             diag_pivot_thresh=0.0, options={"SymmetricMode": True})

    def solve(self, B: np.ndarray) -> np.ndarray:
        return self._lu.solve(np.asarray(B, dtype=np.float64))


def _upper_csc(A: sp.spmatrix) -> sp.csc_matrix:
    """Upper triangle of a symmetric matrix, csc (= its lower triangle read as csr)."""
    if not (sp.issparse(A) and A.format in ("csr", "csc")):
        A = sp.csc_matrix(A)
    outer = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    keep = A.indices <= outer
    indptr = np.zeros(A.shape[0] + 1, dtype=np.int64)
    np.cumsum(np.bincount(outer[keep], minlength=A.shape[0]), out=indptr[1:])
    return sp.csc_matrix((A.data[keep], A.indices[keep], indptr), shape=A.shape)


def factorize(A: sp.spmatrix, solver: str):
    """Factorise the symmetric matrix A once: the chosen factoriser, then fallbacks.

    "qdldl" falls back to cholespy if the wheel is missing; "cholespy" (and so
    "qdldl") to SuperLU if CHOLMOD refuses the matrix (e.g. not positive definite).
    """
    global FACTORIZATIONS
    FACTORIZATIONS += 1
    A = sp.csc_matrix(A)
    chain = {"qdldl": (_QdldlFactor, _CholespyFactor), "cholespy": (_CholespyFactor,)}
    for cls in chain.get(solver, ()):
        try:
            return cls(A)
        except (ValueError, RuntimeError, ImportError):
            pass  # e.g. "Matrix is not positive definite": try the next one
    try:
        return _SpluFactor(A)
    except RuntimeError as err:  # exactly singular
        raise ValueError(f"ARAP system is singular ({err}); degenerate triangles?") from err


class SolveThread:
    """A second thread that runs ``fn(arg)`` for each :meth:`submit`, in order.

    :meth:`result` returns the next result or re-raises what ``fn`` raised; with
    ``threaded=False`` the calls run inline, at :meth:`submit`.
    """

    def __init__(self, fn, threaded: bool = True):
        self._fn, self._results = fn, queue.SimpleQueue()
        self._jobs = queue.SimpleQueue() if threaded else None
        if threaded:
            threading.Thread(target=self._loop, daemon=True).start()

    def _run(self, arg):
        try:
            self._results.put((True, self._fn(arg)))
        except BaseException as err:  # handed to the caller's thread
            self._results.put((False, err))

    def _loop(self):
        while (arg := self._jobs.get()) is not None:
            self._run(arg)

    def submit(self, arg):
        if self._jobs is None:
            self._run(arg)
        else:
            self._jobs.put(arg)

    def result(self):
        ok, value = self._results.get()
        if not ok:
            raise value
        return value

    def close(self):
        if self._jobs is not None:
            self._jobs.put(None)


def pair_solver(factor, nf: int, iterations: int):
    """``solve(rhs) -> x`` for both coordinates as complex (nf,), and its closer."""
    if not isinstance(factor, _QdldlFactor):
        def solve(rhs):
            X = factor.solve(rhs.view(np.float64).reshape(nf, 2))
            return np.ascontiguousarray(X, dtype=np.float64).view(np.complex128).ravel()
        return solve, lambda: None
    def pack(x, y):
        z = np.empty(nf, dtype=np.complex128)
        z.real, z.imag = x, y
        return z

    if not (THREADS and nf >= PARALLEL_MIN_FREE and iterations >= PARALLEL_MIN_ITERATIONS):
        return (lambda rhs: pack(factor.solve1(rhs.real), factor.solve1(rhs.imag))), lambda: None
    worker = SolveThread(factor.solve1)

    def solve(rhs):  # y on the worker while x is solved here
        worker.submit(np.ascontiguousarray(rhs.imag))
        x = factor.solve1(np.ascontiguousarray(rhs.real))
        return pack(x, worker.result())
    return solve, worker.close


