"""The step logic every integrator shares, compiled once: a chunk of accepted steps and, after
each, the checks of a run in this order (the order pinclear.simulate has always used):

1. the pivot monitor dipped during the step: search the step for a singular passage (Brent's
   minimiser on the pivot ratio along the dense output); a rank loss there ends the run at its
   time, samples kept up to it;
2. a non-finite state ends the run;
3. events: the channels whose value changed sign in their sense are located on the dense output
   (Brent's root finder); the earliest ends the chunk (the run handles it, then restarts);
4. output samples up to the step's end (or the event): the dense output, as the integration
   knows the motion (a projecting formulation's samples are moved onto the manifold when the
   run's outputs are made, pinclear.dynamics.stepping.run.Run.output_samples: they never feed back);
5. the projection of the state after the step (formulations that project), the right-hand side
   evaluated again at the projected state;
6. a chart too far from its anchor (non-Euclidean trees) ends the chunk to re-anchor;
7. the stall test: the last STALL_STEPS accepted steps advanced time by less than
   STALL_STEPS * h_stall.

A chunk returns to Python every ``max_steps`` accepted steps (progress, checkpoints, the CPU
budget) and for anything only Python does: an event's effect, choosing constraint rows again, a
failure's report. Python-driven integrators (SciPy's) take their steps through a callback and
share everything else.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.call import call_stage
from pinclear.core.jit import njit
from pinclear.dynamics.stepping.checks import BAD, FAILED, GOOD, dipped, first_crossing, observe, stalled
from pinclear.dynamics.stepping.control import ACCEPTED, ASK_RESELECT, BAD_EVALS, TOO_SMALL
from pinclear.dynamics.stepping.peaks import fold, forces_at, stage_forces
from pinclear.dynamics.stepping.rk import rk_dense, rk_dense_at, rk_step
from pinclear.dynamics.stepping.roots import (
    BRENT_STATE,
    ROOT_STATE,
    brent_next,
    brent_root_next,
    brent_root_start,
    brent_start,
)
from pinclear.dynamics.stepping.rosenbrock import rosenbrock_step
from pinclear.dynamics.stepping.state import (
    ATOL,
    CHART,
    DENSE,
    DIRS,
    DX,
    EVENT_K,
    EXTERNAL,
    F_OLD,
    G_NEW,
    G_PREV,
    G_WORK,
    H_ABS,
    H_PREV,
    H_STALL,
    MAX_STEP,
    MON_MIN,
    N_ACC,
    NO_RESELECT,
    OUT_I,
    PK_MAX,
    PK_NOW,
    PK_SLOPE,
    PK_T,
    PK_W1,
    PK_W2,
    PK_W3,
    RK_FIXED,
    ROSENBROCK,
    RTOL,
    STEPS,
    T_BAD,
    T_BOUND,
    T_EVENT,
    T_OLD,
    XB,
    XE,
    Y_NEW,
    Y_OLD,
    YS,
    F,
    T,
    Y,
)
from pinclear.dynamics.stepping.state import BAD as BAD_COUNT
from pinclear.dynamics.stepping.system import evaluate, event_values, peak_values, project

#: what a chunk ended with
(QUIET, FINISHED, EVENT, STALLED, STEP_TOO_SMALL, BAD_EVALUATIONS, RANK_LOSS, NONFINITE_STATE, ASK_ROWS,
 PYTHON_ERROR, RECHART, START_FAILED, PROJECTION_FAILED) = range(13)

#: a step whose pivot ratio dips below this fraction of its first value may have stepped over a
#: singular configuration (the formulations' SINGULAR_DIP)
SINGULAR_DIP = 1e-3
#: most evaluations of the search for a singular passage inside one step
LOCATE_MAXITER = 500
#: most evaluations locating one event crossing
ROOT_MAXITER = 100
#: a chart coordinate beyond this (rad or m) asks for a new anchor
CHART_LIMIT = 0.5
#: size of Steps.search (the larger of Brent's two states)
SEARCH_STATE = max(BRENT_STATE, ROOT_STATE)
#: the contact-force slopes at a step's ends are differences over this fraction of the step
PEAK_DELTA = 1e-6
#: most points of the search for one contact-force peak inside a step
PEAK_MAXITER = 100


# --------------------------------------------------------------------------------- dense output
@njit(cache=True)
def dense_at(sys, tab, st, t, out):
    """The last accepted step's dense output at t, prepared on first use in the step."""
    if tab.kind == EXTERNAL:
        call_stage(tab.ext[1], 0, t)          # the Python integrator writes it into V[XE]
        out[:] = st.V[XE]
        return
    if not st.i[DENSE]:
        rk_dense(sys, tab, st)
        st.i[DENSE] = 1
    rk_dense_at(tab, st.D, st.V[Y_OLD], st.r[T_OLD], st.r[H_PREV], t, out)


@njit(cache=True)
def write_samples(sys, tab, st, t_stop, strict):
    """Output samples at the times up to t_stop (before it when ``strict``) from the last step's
    dense output."""
    te, j = st.t_eval, st.i[OUT_I]
    D, y, y_old, t, t_old, h = st.D, st.V[Y], st.V[Y_OLD], st.r[T], st.r[T_OLD], st.r[H_PREV]
    while j < te.shape[0] and (te[j] < t_stop if strict else te[j] <= t_stop):
        row = st.samples[j]
        if te[j] == t:
            row[:] = y                        # the step's own end (DOP853 saves its extra stages)
        elif tab.kind == EXTERNAL:
            dense_at(sys, tab, st, te[j], row)
        else:
            if not st.i[DENSE]:
                rk_dense(sys, tab, st)
                st.i[DENSE] = 1
            rk_dense_at(tab, D, y_old, t_old, h, te[j], row)
        j += 1
    st.i[OUT_I] = j


# --------------------------------------------------------------------------------- start
@njit(cache=True)
def initial_step(sys, tab, st, t):
    """SciPy's initial step (select_initial_step; Hairer, Norsett & Wanner, Solving ODEs I,
    II.4), bounded by the span and the largest step; -1 when its trial evaluation is bad."""
    V, r = st.V, st.r
    y, f, ys, dx, atol = V[Y], V[F], V[YS], V[DX], V[ATOL]
    n = y.shape[0]
    span = abs(r[T_BOUND] - t)
    if n == 0:
        return np.inf
    if span == 0.0:
        return 0.0
    rtol = r[RTOL]
    d0 = d1 = 0.0
    for i in range(n):
        sc = atol[i] + abs(y[i]) * rtol
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0, d1 = (d0 / n) ** 0.5, (d1 / n) ** 0.5
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    for i in range(n):
        ys[i] = y[i] + h0 * f[i]
    if observe(r, st.i, V[XB], evaluate(sys, t + h0, ys, dx), t + h0, ys) != GOOD:
        return -1.0
    d2 = 0.0
    for i in range(n):
        sc = atol[i] + abs(y[i]) * rtol
        d2 += ((dx[i] - f[i]) / sc) ** 2
    d2 = (d2 / n) ** 0.5 / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (tab.order + 1))
    return min(100.0 * h0, h1, span, r[MAX_STEP])


@njit(cache=True)
def start(sys, tab, st, t, x, h_hint, zero_channel):
    """(Re)start the integration at (t, x): f there, the first step (``h_hint`` > 0, else SciPy's
    choice), the event values (channel ``zero_channel`` >= 0 set to zero: it sits on its event
    right after it, and is stepped off in its sense). Returns QUIET, or START_FAILED /
    PYTHON_ERROR when an evaluation there is bad (the run reports it)."""
    V, r = st.V, st.r
    y = V[Y]
    y[:] = x
    r[T] = t
    r[T_OLD] = t
    st.i[DENSE] = 0
    v = observe(r, st.i, V[XB], evaluate(sys, t, y, V[F]), t, y)
    if v == FAILED:
        return PYTHON_ERROR
    if v == BAD:
        return START_FAILED
    forces_at(sys, st.pk, t)
    if h_hint > 0.0:
        r[H_ABS] = h_hint
    elif tab.kind != EXTERNAL and tab.kind != RK_FIXED:
        h = initial_step(sys, tab, st, t)
        if h < 0.0:
            return PYTHON_ERROR if st.i[BAD_COUNT] == 0 else START_FAILED
        r[H_ABS] = h
    if st.G.shape[1]:
        event_values(sys, t, y, st.G[G_PREV])
        if zero_channel >= 0:
            st.G[G_PREV, zero_channel] = 0.0
    if sys.pval.shape[0]:
        c0 = st.pk.shape[1] - sys.pval.shape[0]
        peak_values(sys, t, y, st.pk[PK_NOW, c0:])
        fold(st.pk, c0, st.pk.shape[1], t)
        st.pk[PK_SLOPE, c0:] = np.nan          # not known until a step is taken from here
    return QUIET


# --------------------------------------------------------------------------------- after a step
@njit(cache=True)
def search_dip(sys, tab, st):
    """Brent's minimiser on the pivot ratio along the step's dense output (the search's
    evaluations leave the step's monitor as it was). Returns GOOD, or BAD with the rank loss's
    time and state recorded (observe), or FAILED."""
    r, V = st.r, st.V
    t_old, t = r[T_OLD], r[T]
    xe, dx, xb = V[XE], V[DX], V[XB]
    xatol = 1e-13 * max(1.0, t)
    keep = r[MON_MIN]
    s = brent_start(t_old, t, xatol, st.search)
    while True:
        dense_at(sys, tab, st, s, xe)
        code = evaluate(sys, s, xe, dx)
        r[MON_MIN] = np.inf
        v = observe(r, st.i, xb, code, s, xe)
        if v == BAD or v == FAILED:
            r[MON_MIN] = keep
            return v
        s, done = brent_next(st.search, code, LOCATE_MAXITER)
        if done:
            r[MON_MIN] = keep
            return GOOD


@njit(cache=True)
def locate_event(sys, tab, st):
    """The earliest event crossing in the last step: its channel (-1 if none) with its time in
    st.r[T_EVENT] and its state in V[XE]; G[G_NEW] holds the values at the step's end."""
    r, G, xe = st.r, st.G, st.V[XE]
    t_old, t = r[T_OLD], r[T]
    g0, g1, g, dirs = G[G_PREV], G[G_NEW], G[G_WORK], G[DIRS]
    event_values(sys, t, st.V[Y], g1)
    hit, te = -1, t
    k = first_crossing(g0, g1, dirs, 0)
    while k >= 0:
        s, done = brent_root_start(t_old, t, g0[k], g1[k], 1e-14, 4.0 * np.finfo(np.float64).eps, st.search)
        while not done:
            dense_at(sys, tab, st, s, xe)
            event_values(sys, s, xe, g)
            s, done = brent_root_next(st.search, g[k], ROOT_MAXITER)
        if hit < 0 or s < te:
            hit, te = k, s
        k = first_crossing(g0, g1, dirs, k + 1)
    if hit >= 0:
        r[T_EVENT] = te
        dense_at(sys, tab, st, te, xe)
    return hit


@njit(cache=True)
def contact_peaks(sys, tab, st, t_stop):
    """The contact-force peaks of the last step, [T_OLD, t_stop] (t_stop: its end or its
    event): the force at t_stop and, where it rises at the step's start and falls at its end,
    the maximum between, located by Brent's minimiser on the dense output (pinclear.dynamics.stepping.
    peaks). The states it evaluates go to V[Y_NEW], free after an accepted step."""
    pk, x = st.pk, st.V[Y_NEW]
    c0 = pk.shape[1] - sys.pval.shape[0]
    t_old = st.r[T_OLD]
    dt = PEAK_DELTA * (t_stop - t_old)
    if not dt > 0.0:
        return
    end, before, work = pk[PK_W1, c0:], pk[PK_W2, c0:], pk[PK_W3, c0:]
    # the slopes at the ends along f there (no dense output: DOP853's costs three evaluations)
    V = st.V
    if t_stop == st.r[T]:
        peak_values(sys, t_stop, V[Y], end)
        if tab.kind == EXTERNAL:
            dense_at(sys, tab, st, t_stop - dt, x)
        else:
            for i in range(x.shape[0]):
                x[i] = V[Y, i] - dt * V[F, i]
    else:
        dense_at(sys, tab, st, t_stop, x)
        peak_values(sys, t_stop, x, end)
        dense_at(sys, tab, st, t_stop - dt, x)
    peak_values(sys, t_stop - dt, x, before)
    if pk[PK_SLOPE, c0] != pk[PK_SLOPE, c0]:          # the first step after a (re)start
        if tab.kind == EXTERNAL:
            dense_at(sys, tab, st, t_old + dt, x)
        else:
            for i in range(x.shape[0]):
                x[i] = V[Y_OLD, i] + dt * V[F_OLD, i]
        peak_values(sys, t_old + dt, x, work)
        for j in range(c0, pk.shape[1]):
            pk[PK_SLOPE, j] = pk[PK_W3, j] - pk[PK_NOW, j]
    for j in range(c0, pk.shape[1]):
        s1 = pk[PK_W1, j] - pk[PK_W2, j]
        if pk[PK_SLOPE, j] > 0.0 and s1 < 0.0:
            s, done = brent_start(t_old, t_stop, 1e-13 * max(1.0, abs(t_stop)), st.search), False
            while not done:
                dense_at(sys, tab, st, s, x)
                peak_values(sys, s, x, work)
                s, done = brent_next(st.search, -pk[PK_W3, j], PEAK_MAXITER)
            dense_at(sys, tab, st, s, x)
            peak_values(sys, s, x, work)
            if pk[PK_W3, j] > pk[PK_MAX, j]:
                pk[PK_MAX, j] = pk[PK_W3, j]
                pk[PK_T, j] = s
        pk[PK_SLOPE, j] = s1
        pk[PK_NOW, j] = pk[PK_W1, j]
    fold(pk, c0, pk.shape[1], t_stop)


@njit(cache=True)
def after_step(sys, tab, st):
    """The checks after an accepted step (the module doc); -1 to go on, else a chunk code."""
    r, ii, y = st.r, st.i, st.V[Y]
    t = r[T]
    # the drive-force and acceleration peaks of the evaluation at the accepted state (each
    # compiled method's last; a Python-driven one's only when it was there)
    at_state = tab.kind != EXTERNAL
    if not at_state:
        at_state = True
        for i in range(y.shape[0]):
            if sys.x[i] != y[i]:
                at_state = False
    if at_state:
        stage_forces(sys, st.pk)
    if dipped(r, SINGULAR_DIP):
        v = search_dip(sys, tab, st)
        if v == FAILED:
            return PYTHON_ERROR
        if v == BAD:
            write_samples(sys, tab, st, r[T_BAD], True)
            return RANK_LOSS
    r[MON_MIN] = np.inf
    ii[NO_RESELECT] = 0
    if not np.isfinite(y.sum()):
        return NONFINITE_STATE
    hit = locate_event(sys, tab, st) if st.G.shape[1] else -1
    t_stop = r[T_EVENT] if hit >= 0 else t
    if ii[OUT_I] < st.t_eval.shape[0] and st.t_eval[ii[OUT_I]] <= t_stop:
        write_samples(sys, tab, st, t_stop, False)
    if sys.pval.shape[0]:
        contact_peaks(sys, tab, st, t_stop)
        if hit >= 0 and tab.kind == EXTERNAL:
            dense_at(sys, tab, st, t_stop, st.V[XE])     # the event's state, which the search moved
    if hit >= 0:
        ii[EVENT_K] = hit
        return EVENT
    if st.G.shape[1]:
        st.G[G_PREV, :] = st.G[G_NEW]
    if sys.project.shape[0]:
        if not project(sys, t, y) >= 0.0:
            return PROJECTION_FAILED
        v = observe(r, ii, st.V[XB], evaluate(sys, t, y, st.V[F]), t, y)
        if v == FAILED:
            return PYTHON_ERROR
        stage_forces(sys, st.pk)
        at_state = True
        if tab.kind == EXTERNAL:
            call_stage(tab.ext[2], 0, t)      # the state goes back into the Python integrator
    if at_state:
        fold(st.pk, 0, sys.drows.shape[0] + sys.a.shape[0], t)
    if ii[CHART]:
        nc = y.shape[0] - sys.a.shape[0] - sys.zdot.shape[0]
        for i in range(nc):
            if abs(y[i]) > CHART_LIMIT:
                return RECHART
    stop, ii[N_ACC] = stalled(st.ring, ii[N_ACC], t, r[H_STALL], t - r[T_BOUND] >= 0)
    if stop:
        return STALLED
    return -1


# --------------------------------------------------------------------------------- the chunk
@njit(cache=True)
def step(sys, tab, st):
    """One accepted step of the integrator's kind (or its failure code, rk.ACCEPTED etc.)."""
    if tab.kind == EXTERNAL:
        return int(call_stage(tab.ext[0], 0, st.r[T]))
    if tab.kind == ROSENBROCK:
        return rosenbrock_step(sys, tab, st)
    return rk_step(sys, tab, st)


@njit(cache=True)
def advance(sys, tab, st, max_steps):
    """Up to ``max_steps`` accepted steps with their checks; the chunk code (module doc)."""
    done = 0
    while True:
        r = step(sys, tab, st)
        if r != ACCEPTED:
            if r == TOO_SMALL:
                return STEP_TOO_SMALL
            if r == BAD_EVALS:
                return BAD_EVALUATIONS
            if r == ASK_RESELECT:
                return ASK_ROWS
            return PYTHON_ERROR
        st.i[STEPS] += 1
        done += 1
        code = after_step(sys, tab, st)
        if code >= 0:
            return code
        if st.r[T] - st.r[T_BOUND] >= 0:
            return FINISHED
        if done >= max_steps:
            return QUIET
