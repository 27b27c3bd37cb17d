"""Contours: what a simplification may cut from a region (issue 32, edge pixels that did not render)."""
import numpy as np

from puppet.geom.contour import keep_outside


def test_keep_outside_puts_back_what_cuts_into_the_region():
    # a square with a 1 px bump outward on its right side (counter-clockwise in y-up: area > 0)
    P = np.array([[0, 0], [10, 0], [10, 4], [11, 5], [10, 6], [10, 10], [0, 10], [0, 5]], float)
    Q = P[[0, 1, 5, 6]]  # the bump dropped: the edge (10,0)-(10,10) cuts 1 px into the region
    out = keep_outside(P, Q, hole=False)
    assert [tuple(p) for p in out] == [(0, 0), (10, 0), (11, 5), (10, 10), (0, 10)]
    # a notch inward dropped: the simplification bulges out of the region, nothing to put back
    R = P.copy()
    R[3] = [9, 5]
    assert keep_outside(R, R[[0, 1, 5, 6]], hole=False) is not None and len(keep_outside(R, R[[0, 1, 5, 6]], hole=False)) == 4
    # as a hole the region lies outside the ring: the bump outward is now a notch of the region
    assert len(keep_outside(P, Q, hole=True)) == 4 and len(keep_outside(R, R[[0, 1, 5, 6]], hole=True)) == 5
