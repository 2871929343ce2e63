"""The per-step checks of a run, compiled once for every integrator: event crossings, the stall
test and the pivot monitor of a constraint solve (pinclear.dynamics.stepping.chunk calls them)."""
from __future__ import annotations

import numpy as np

from pinclear.core.call import ERROR
from pinclear.core.jit import njit
from pinclear.dynamics.stepping.state import BAD as BAD_COUNT
from pinclear.dynamics.stepping.state import CODE_BAD, MON_FLOOR, MON_MIN, MON_REF, MON_RESELECT, NO_RESELECT, T_BAD

#: monitor verdicts on one evaluation
GOOD, BAD, RESELECT, FAILED = 0, 1, 2, 3



def reset_monitor(r, floor=0.0, reselect=-np.inf):
    """A fresh monitor in Steps.r. floor: a code below it is a bad evaluation (rank loss);
    reselect: a ratio below reselect times the run's first asks for the rows to be chosen again."""
    r[MON_MIN], r[MON_REF], r[MON_FLOOR], r[MON_RESELECT] = np.inf, np.nan, floor, reselect


@njit(cache=True)
def first_crossing(g0, g1, dirs, start):
    """Index of the first event channel from ``start`` whose value changed sign between g0 and
    g1 in the sense it watches (direction +1: rising, -1: falling, 0: both); -1 when none."""
    for k in range(start, g0.shape[0]):
        a, b, d = g0[k], g1[k], dirs[k]
        if (a < 0 <= b and d >= 0) or (a > 0 >= b and d <= 0):
            return k
    return -1


@njit(cache=True)
def stalled(ring, n_acc, t, h_stall, finished):
    """The stall test after an accepted step reaching t: the last ring.shape[0] accepted steps
    advanced time by less than ring.shape[0] * h_stall (a step-size collapse). When not stalled
    the step is recorded in the ring; returns (stalled, n_acc)."""
    n = ring.shape[0]
    k = n_acc % n
    if n_acc >= n and t - ring[k] < n * h_stall and not finished:
        return True, n_acc
    ring[k] = t
    return False, n_acc + 1


@njit(cache=True)
def monitor(code, rr, reselect=True):
    """The verdict on an evaluation whose code is ``code``, for the monitor in ``rr`` (Steps.r):
    FAILED (a Python stage raised), BAD (below the rank floor or non-finite: the trial step is
    rejected), RESELECT (the pivots of the kept constraint rows fell below the reselect factor
    times the run's first ratio: the rows are chosen again) or GOOD, the monitor then holding the
    smallest ratio since the last step and the run's first ratio. ``reselect`` False: no
    RESELECT verdict (the rows were chosen again during this step)."""
    if code == ERROR:
        return FAILED
    if not code >= rr[MON_FLOOR]:
        return BAD
    if reselect and code < rr[MON_RESELECT] * rr[MON_REF]:
        return RESELECT
    if code < rr[MON_MIN]:
        rr[MON_MIN] = code
        if rr[MON_REF] != rr[MON_REF]:
            rr[MON_REF] = code
    return GOOD


@njit(cache=True)
def dipped(rr, dip):
    """Whether the pivots dipped below ``dip`` times the run's first ratio during the step."""
    return rr[MON_REF] == rr[MON_REF] and rr[MON_MIN] < dip * rr[MON_REF]


@njit(cache=True)
def observe(rr, ii, xb, code, t, x):
    """The monitor's verdict on an evaluation at (t, x) during a step (see :func:`monitor`), for
    the step state's floats ``rr`` and ints ``ii`` (Steps.r, .i) and bad-state buffer ``xb``. A
    bad evaluation is recorded (its time, code and state: the run reports it if the steps cannot
    get past it); a good one resets the count of consecutive bad ones."""
    v = monitor(code, rr, ii[NO_RESELECT] == 0)
    if v == GOOD:
        ii[BAD_COUNT] = 0
    elif v == BAD:
        ii[BAD_COUNT] += 1
        rr[T_BAD] = t
        rr[CODE_BAD] = code
        for k in range(x.shape[0]):
            xb[k] = x[k]
    elif v == RESELECT:
        rr[T_BAD] = t
        for k in range(x.shape[0]):
            xb[k] = x[k]
    return v
