"""Work budgets: every solve is bounded by a count of work units, not by luck.

A **work unit** is the cost of one ARAP local/global iteration on the mesh at hand: the
sparse products over the Laplacian's pattern and one solve per coordinate with the
precomputed factor. A plain ``arap_solve`` costs ``iterations`` units (20 by default)
plus its initial guess. Everything else the relaxation does is charged in these units
by a cost model of the sizes it works on (counts of triangles, vertices and solves, never
measured time), so the same input always does the same work and gives the same shape:

=============================================  =========================================
operation                                      units charged
=============================================  =========================================
similarity iteration (ARAP factor reused)      1
fold check over the whole mesh                 ``CHECK``
rings around the folds, one untangling region  ``REGION``
setting up an untangling region                ``SETUP_TRI * t + SETUP_MESH``
Newton step of the untangling, region of       ``NEWTON_TRI * t + NEWTON_SOLVE * p ** 1.5``
``t`` triangles and ``p`` vertices (shares of  ``+ NEWTON_FIXED / n`` (assembly with the
the mesh's ``m`` and ``n``)                    PSD projection; sparse LDL^T and solve)
energy evaluation in its line search           ``EVAL_TRI * t + EVAL_FIXED / n``
=============================================  =========================================

The ``*_FIXED`` terms are the interpreter's fixed cost of an operation, as the number of
vertices whose ARAP iteration takes as long: they matter on small regions of small
meshes. The constants are measured ratios on the 5k and 20k discs of
``benchmarks/bench_fardrag.py``.

A time cap backs the count up: :class:`Budget` also stops once ``TIME_CAP`` times the
time the budget should take has passed (the time of one unit is measured on the first
fold check). Both are the calling thread's CPU time (``time.thread_time``), not the wall
clock: a busy machine slows the thread down but does not charge it for the time other
processes run, so the cap only fires on runaway work (with wall-clock time, linear
in-betweens lost their relaxation at load 17). Reaching it makes the result depend on
timing; ``Budget.late`` says so.
"""
from __future__ import annotations

import time

__all__ = ["Budget", "CHECK", "REGION", "NEWTON_TRI", "NEWTON_SOLVE", "NEWTON_FIXED", "EVAL_TRI",
           "EVAL_FIXED", "SETUP_TRI", "SETUP_MESH", "TIME_CAP", "newton_cost", "eval_cost",
           "setup_cost"]

#: Units of one fold check (signed areas of every triangle; measured 0.2-0.4).
CHECK = 0.4
#: Units of a Newton step over all the triangles of the mesh (assembly of the 6x6
#: element Hessians with their positive semi-definite projection; measured 5-11) ...
NEWTON_TRI = 10.0
#: ... and for all its vertices moving (factorisation with the symbolic analysis reused,
#: and solve; measured 35-45, growing as (p / n) ** 1.5 from 5 % of the mesh on).
NEWTON_SOLVE = 50.0
#: Units of setting up an untangling region over all the triangles of the mesh (the
#: sparsity pattern of its Hessian; measured 10-20, a sort of 21 keys per triangle) ...
SETUP_TRI = 20.0
#: ... plus its passes over the whole mesh (measured 0.6).
SETUP_MESH = 0.8
#: Units of the ring distances around the folds or of one region built from them (passes
#: over the whole mesh).
REGION = 0.5
#: Fixed cost of a Newton step, in vertices (measured 0.5-0.8 units at 5069 vertices).
NEWTON_FIXED = 4000.0
#: Fixed cost of an energy evaluation, in vertices (measured 0.1-0.17 units at 5069).
EVAL_FIXED = 900.0
#: Units of one evaluation of the untangling energy over all the triangles of the mesh
#: (measured 0.7-1.4).
EVAL_TRI = 1.5
#: The time cap, as a multiple of the expected time of the whole budget.
TIME_CAP = 10.0
#: Floor of the time cap, seconds (timer resolution, a cold cache).
TIME_CAP_MIN = 0.05


def newton_cost(t: float, p: float, n: int) -> float:
    """Units of a Newton step over a share ``t`` of the triangles and ``p`` of the
    vertices of an ``n``-vertex mesh."""
    return NEWTON_TRI * t + NEWTON_SOLVE * p ** 1.5 + NEWTON_FIXED / max(n, 1)


def eval_cost(t: float, n: int) -> float:
    """Units of an energy evaluation over a share ``t`` of the triangles."""
    return EVAL_TRI * t + EVAL_FIXED / max(n, 1)


def setup_cost(t: float) -> float:
    """Units of setting up an untangling region over a share ``t`` of the triangles."""
    return SETUP_TRI * t + SETUP_MESH


#: The clock of the safety cap: this thread's CPU time (other processes' load does not count).
clock = time.thread_time


class Budget:
    """A count of work units with a CPU-time safety cap.

    Parameters
    ----------
    units : float
        Work units that may be spent.
    time_limit : float or None
        Seconds after which :meth:`affords` refuses everything. ``None``: set by
        :meth:`calibrate` to ``TIME_CAP`` times the expected time of ``units``.
    """

    def __init__(self, units: float, time_limit: float | None = None):
        self.units = float(units)
        self.used = 0.0
        self.start = clock()
        self.deadline = None if time_limit is None else self.start + float(time_limit)
        self.late = False

    def calibrate(self, seconds_per_unit: float) -> None:
        """Set the cap from the measured time of one unit (unless a limit was given)."""
        if self.deadline is None:
            cap = max(TIME_CAP_MIN, TIME_CAP * self.units * max(seconds_per_unit, 0.0))
            self.deadline = self.start + cap

    @property
    def left(self) -> float:
        return self.units - self.used

    def affords(self, cost: float) -> bool:
        """Whether ``cost`` more units fit (and the time cap is not reached)."""
        if self.deadline is not None and clock() > self.deadline:
            self.late = True
            return False
        return self.used + cost <= self.units

    def charge(self, cost: float) -> None:
        self.used += cost
