"""The step-size control every adaptive method of the step logic shares (pinclear.dynamics.stepping.rk,
.rosenbrock): SciPy's controller (scipy.integrate RungeKutta._step_impl; E. Hairer, S. P.
Norsett, G. Wanner, Solving ODEs I, sec. II.4): the next step h |err|^(-1/(order+1)) times 0.9,
growth at most 10 (none after a rejection), shrinking at least 5; a step below 10 ulp of t
fails. And what an evaluation's verdict (pinclear.dynamics.stepping.checks.monitor) means for a step."""
from __future__ import annotations

import numpy as np

from pinclear.core.jit import njit
from pinclear.dynamics.stepping.checks import BAD, FAILED, RESELECT
from pinclear.dynamics.stepping.state import BAD as BAD_COUNT
from pinclear.dynamics.stepping.state import H_ABS, H_START, MAX_STEP, REJECTS, T

#: outcomes of one step (pinclear.dynamics.stepping.chunk.advance passes the failures on)
ACCEPTED, TOO_SMALL, BAD_EVALS, ASK_RESELECT, STAGE_ERROR = range(5)
#: consecutive bad evaluations (rejected trial stages) before a run fails
MAX_BAD = 50
#: a step's outcome is still open (the attempt goes on)
GO_ON = -1


@njit(cache=True)
def begin(r, order):
    """(min_step, h_abs, exponent) for the attempts of a step from r[T] with the step r[H_ABS]
    (clamped to r[MAX_STEP] and above the minimum), which r[H_START] keeps: a step handed back
    (ASK_RESELECT) is redone from it."""
    t = r[T]
    r[H_START] = r[H_ABS]
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    h_abs = min(r[H_ABS], r[MAX_STEP])
    return min_step, max(h_abs, min_step), -1.0 / (order + 1)


@njit(cache=True)
def propose(t, h_abs, t_bound):
    """(t_new, h, |h|) of an attempt of size h_abs, cut at t_bound."""
    t_new = t + h_abs
    if t_new - t_bound > 0:
        t_new = t_bound
    h = t_new - t
    return t_new, h, abs(h)


@njit(cache=True)
def grown(err, expo, rejected):
    """The factor on the next step after an accepted one with error norm err < 1."""
    factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** expo)
    return min(1.0, factor) if rejected else factor


@njit(cache=True)
def shrunk(h_abs, err, expo, ii):
    """The step after a rejected attempt (err >= 1, or NaN: a bad evaluation shrinks by 5 too)."""
    ii[REJECTS] += 1
    factor = 0.9 * err ** expo
    return h_abs * (factor if factor > 0.2 else 0.2)


@njit(cache=True)
def outcome(v, r, ii):
    """What an evaluation's verdict means for the step: GO_ON (good, or a bad evaluation that
    rejects the attempt: the caller sets its error to NaN), or the step's outcome: STAGE_ERROR (a
    Python stage raised), ASK_RESELECT (the step starts again from r[H_START] after the run chose
    other constraint rows), BAD_EVALS (more than MAX_BAD bad evaluations in a row)."""
    if v == FAILED:
        return STAGE_ERROR
    if v == RESELECT:
        r[H_ABS] = r[H_START]
        return ASK_RESELECT
    if v == BAD and ii[BAD_COUNT] > MAX_BAD:
        return BAD_EVALS
    return GO_ON
