"""The per-step checks of a run, compiled once and called by both the compiled loop and the
Python driver (pinclear.simulate): event crossings, the stall test and the pivot monitor of a
constraint solve."""
from __future__ import annotations

import numpy as np

from .._jit import njit


@njit(cache=True)
def first_crossing(g0, g1, dirs, start):
    """Index of the first event channel from ``start`` whose value changed sign between g0 and
    g1 in the sense it watches (direction +1: rising, -1: falling, 0: both); -1 when none."""
    for k in range(start, g0.shape[0]):
        a, b, d = g0[k], g1[k], dirs[k]
        if (a < 0 <= b and d >= 0) or (a > 0 >= b and d <= 0):
            return k
    return -1


def crossings(g0, g1, dirs):
    """Every channel that crossed (see first_crossing), as a list of indices."""
    out, k = [], first_crossing(g0, g1, dirs, 0)
    while k >= 0:
        out.append(k)
        k = first_crossing(g0, g1, dirs, k + 1)
    return out


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
def monitor(r, mon):
    """The pivot monitor of a constraint solve, for an evaluation whose pivot ratio (or code) is
    r. mon = [smallest ratio since the last step, first ratio (nan before), rank floor, ratio
    below which dropped rows are chosen again (relative to the first; -inf: never)]. False:
    Python must take this evaluation (non-finite, rank loss, rows to choose again); True: the
    monitor is updated."""
    if not r >= mon[2]:
        return False
    if r >= 0.0 and r < mon[3] * mon[1]:
        return False
    if r < mon[0]:
        mon[0] = r
        if mon[1] != mon[1]:
            mon[1] = r
    return True


@njit(cache=True)
def dipped(mon, dip):
    """Whether the pivots dipped below ``dip`` times their first value during the step."""
    return mon[1] == mon[1] and mon[0] < dip * mon[1]


def new_monitor(floor, reselect=-np.inf):
    return np.array([np.inf, np.nan, floor, reselect])
