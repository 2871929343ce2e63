"""Explicit Runge-Kutta methods: RK45 (Dormand-Prince 5(4)), DOP853 (Dormand-Prince 8(5,3))
and the classical fixed-step RK4. The coefficients are SciPy's (scipy.integrate.RK45 / DOP853),
and so are the error norms, the step-size control and the dense output (E. Hairer, S. P.
Norsett, G. Wanner, Solving ODEs I, sec. II.4, II.6 and II.10), so a run takes the steps SciPy's
solve_ivp takes on the same right-hand side; every stage runs compiled.
"""
from __future__ import annotations

import numpy as np
from scipy import integrate as spi

from pinclear.core.jit import njit
from pinclear.dynamics.stepping.base import Method
from pinclear.dynamics.stepping.checks import BAD, GOOD, observe
from pinclear.dynamics.stepping.control import (
    ACCEPTED,
    BAD_EVALS,
    GO_ON,
    TOO_SMALL,
    begin,
    grown,
    outcome,
    propose,
    shrunk,
)
from pinclear.dynamics.stepping.state import (
    ATOL,
    DENSE,
    F_OLD,
    H_ABS,
    H_FIXED,
    H_PREV,
    H_START,
    RK_DOP853,
    RK_EMBEDDED,
    RK_FIXED,
    RTOL,
    T_BOUND,
    T_OLD,
    XB,
    Y_NEW,
    Y_OLD,
    YS,
    F,
    T,
    Y,
    tableau,
)
from pinclear.dynamics.stepping.system import evaluate


def rk45():
    c = spi.RK45
    return tableau(RK_EMBEDDED, c.error_estimator_order, A=c.A, B=c.B, C=c.C, E=c.E, P=c.P)


def dop853():
    c = spi.DOP853
    return tableau(RK_DOP853, c.error_estimator_order, A=c.A, B=c.B, C=c.C, E3=c.E3, E5=c.E5, AX=c.A_EXTRA,
                   CX=c.C_EXTRA, DX=c.D)


def rk4():
    """The classical RK4 (Kutta 1901); its step is Steps.r[H_FIXED]."""
    return tableau(RK_FIXED, 3, A=[[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]],
                   B=[1 / 6, 1 / 3, 1 / 3, 1 / 6], C=[0, 0.5, 0.5, 1])


@njit(cache=True)
def stage_state(y, K, a, s, h, out):
    """out = y + h sum_{j<s} a_j K_j: the state of stage s."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += K[j, i] * a[j]
        out[i] = y[i] + acc * h


@njit(cache=True)
def _stages(sys, tab, st, t, h):
    """Stages 1..s-1 and f at the proposed state (into K[s]); the first verdict that is not
    GOOD stops them (a rejected trial step needs no more)."""
    K, V, rr, ii, ns = st.K, st.V, st.r, st.i, tab.B.shape[0]
    y, ys, y_new, xb = V[Y], V[YS], V[Y_NEW], V[XB]
    K[0, :] = V[F]
    for s in range(1, ns + 1):
        if s < ns:
            stage_state(y, K, tab.A[s], s, h, ys)
            x, ts = ys, t + tab.C[s] * h
        else:
            stage_state(y, K, tab.B, ns, h, y_new)
            x, ts = y_new, t + h
        v = observe(rr, ii, xb, evaluate(sys, ts, x, K[s]), ts, x)
        if v != 0:
            return v
    return 0


@njit(cache=True)
def error_norm(tab, st, h):
    """SciPy's error norm of the step just computed: RMS of (sum E_j K_j) h / scale for RK45;
    DOP853's err5^2 / sqrt(err5^2 + 0.01 err3^2) (both with scale = atol + max(|y|, |y_new|) rtol)."""
    K, V, rtol = st.K, st.V, st.r[RTOL]
    y, y_new, atol = V[Y], V[Y_NEW], V[ATOL]
    n = y.shape[0]
    if tab.kind == RK_DOP853:
        e5 = e3 = 0.0
        for i in range(n):
            sc = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol
            a5 = a3 = 0.0
            for j in range(tab.E5.shape[0]):
                a5 += K[j, i] * tab.E5[j]
                a3 += K[j, i] * tab.E3[j]
            e5 += (a5 / sc) ** 2
            e3 += (a3 / sc) ** 2
        if e5 == 0.0 and e3 == 0.0:
            return 0.0
        return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * n)
    acc = 0.0
    for i in range(n):
        e = 0.0
        for j in range(tab.E.shape[0]):
            e += K[j, i] * tab.E[j]
        e = e * h / (atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol)
        acc += e * e
    return (acc / n) ** 0.5


@njit(cache=True)
def accept(V, r, ii, f_new, t_new, h, h_abs):
    """The proposed state becomes the current one (as OdeSolver.step); f_new is f there."""
    V[Y_OLD, :] = V[Y]
    V[F_OLD, :] = V[F]
    V[Y, :] = V[Y_NEW]
    V[F, :] = f_new
    r[T_OLD] = r[T]
    r[T] = t_new
    r[H_PREV] = h
    r[H_ABS] = h_abs
    ii[DENSE] = 0


@njit(cache=True)
def rk_step(sys, tab, st):
    """One accepted step from (t, y, f) with SciPy's step-size control (control.py), or why not:
    TOO_SMALL (the step fell below 10 ulp of t), BAD_EVALS (more than MAX_BAD bad evaluations in
    a row, or one with the fixed step, which cannot be retried), ASK_RESELECT (the monitor asks
    for other constraint rows: nothing has changed, the step is redone after) or STAGE_ERROR (a
    Python stage raised). A bad trial stage (rank loss, non-finite) rejects the attempt like an
    error norm above one, shrinking the step by 5."""
    r, ii, ns = st.r, st.i, tab.B.shape[0]
    t, t_bound = r[T], r[T_BOUND]
    if tab.kind == RK_FIXED:
        r[H_START] = r[H_ABS]
        h = min(r[H_FIXED], t_bound - t)
        v = _stages(sys, tab, st, t, h)
        if v != GOOD:
            o = outcome(v, r, ii)
            return BAD_EVALS if o == GO_ON else o
        accept(st.V, r, ii, st.K[ns], t + h if t + h < t_bound else t_bound, h, r[H_ABS])
        return ACCEPTED
    min_step, h_abs, expo = begin(r, tab.order)
    rejected = False
    while True:
        if h_abs < min_step:
            r[H_ABS] = h_abs
            return TOO_SMALL
        t_new, h, h_abs = propose(t, h_abs, t_bound)
        v = _stages(sys, tab, st, t, h)
        o = outcome(v, r, ii)
        if o != GO_ON:
            return o
        err = np.nan if v == BAD else error_norm(tab, st, h)
        if err < 1.0:
            accept(st.V, r, ii, st.K[ns], t_new, h, h_abs * grown(err, expo, rejected))
            return ACCEPTED
        h_abs = shrunk(h_abs, err, expo, ii)
        rejected = True


@njit(cache=True)
def rk_dense(sys, tab, st):
    """The dense output coefficients of the last step into st.D (SciPy's RkDenseOutput /
    Dop853DenseOutput); DOP853 evaluates its three extra stages here, only for steps whose
    dense output is needed."""
    K, D, V = st.K, st.D, st.V
    y, y_old, f, f_old = V[Y], V[Y_OLD], V[F], V[F_OLD]
    n = y.shape[0]
    h = st.r[H_PREV]
    if tab.kind == RK_DOP853:
        ns = tab.B.shape[0]
        t_old = st.r[T_OLD]
        ys = V[YS]
        for e in range(tab.CX.shape[0]):
            s = ns + 1 + e
            for i in range(n):
                acc = 0.0
                for j in range(s):
                    acc += K[j, i] * tab.AX[e, j]
                ys[i] = y_old[i] + acc * h
            te = t_old + tab.CX[e] * h
            observe(st.r, st.i, V[XB], evaluate(sys, te, ys, K[s]), te, ys)
        for i in range(n):
            dy = y[i] - y_old[i]
            D[0, i] = dy
            D[1, i] = h * f_old[i] - dy
            D[2, i] = 2.0 * dy - h * (f[i] + f_old[i])
            for r in range(tab.DX.shape[0]):
                acc = 0.0
                for j in range(tab.DX.shape[1]):
                    acc += tab.DX[r, j] * K[j, i]
                D[3 + r, i] = h * acc
    elif tab.kind == RK_EMBEDDED:
        for k in range(tab.P.shape[1]):
            for i in range(n):
                acc = 0.0
                for j in range(tab.P.shape[0]):
                    acc += K[j, i] * tab.P[j, k]
                D[k, i] = acc
    else:                                   # cubic Hermite over the step (RK4)
        D[0, :] = y_old
        D[1, :] = y
        D[2, :] = f_old
        D[3, :] = f


@njit(cache=True)
def rk_dense_at(tab, D, y_old, t_old, h, t, out):
    """The last step's dense output at t (after rk_dense)."""
    n = y_old.shape[0]
    x = (t - t_old) / h
    if tab.kind == RK_DOP853:
        for i in range(n):
            acc = 0.0
            for r in range(6, -1, -1):
                acc += D[r, i]
                acc *= x if (6 - r) % 2 == 0 else 1.0 - x
            out[i] = acc + y_old[i]
    elif tab.kind == RK_EMBEDDED:
        for i in range(n):
            acc, p = 0.0, 1.0
            for k in range(tab.P.shape[1]):
                p *= x
                acc += D[k, i] * p
            out[i] = h * acc + y_old[i]
    else:
        h00, h10 = (2.0 * x - 3.0) * x * x + 1.0, ((x - 2.0) * x + 1.0) * x
        h01, h11 = (3.0 - 2.0 * x) * x * x, (x - 1.0) * x * x
        for i in range(n):
            out[i] = h00 * D[0, i] + h10 * h * D[2, i] + h01 * D[1, i] + h11 * h * D[3, i]


# --------------------------------------------------------------------------------- the methods
class ExplicitRK(Method):
    """An explicit Runge-Kutta method of the compiled step logic given by its coefficients:
    ``make()`` returns its Tableau (rk45, dop853, rk4 above; any Butcher tableau of kind
    RK_FIXED takes fixed steps with a cubic Hermite dense output); ``rows``: its stages + 1
    (K holds f at the proposed state after the stages; DOP853 its extra dense-output stages)."""

    def __init__(self, name, make, rows, adaptive=True, doc=""):
        self.name, self.make, self.rows, self.adaptive, self.__doc__ = name, make, rows, adaptive, doc

    def tableau(self, run):
        return self.make()


#: the registered explicit methods (pinclear.core.registry.INTEGRATORS)
RK45 = ExplicitRK("RK45", rk45, 7, doc="Dormand-Prince 5(4) (SciPy's RK45): the default; explicit, for non-stiff "
                  "motion and contact resolved by the tolerance.")
DOP853 = ExplicitRK("DOP853", dop853, 16, doc="Dormand-Prince 8(5,3) (SciPy's DOP853): tight tolerances (rtol "
                    "1e-9 and below).")
RK4 = ExplicitRK("RK4", rk4, 5, adaptive=False, doc="Classical fixed-step Runge-Kutta 4 (step h); a failed "
                 "evaluation ends the run (a fixed step cannot be retried).")
