"""pinclear's implicit integrator: ROS34PW2, the linearly implicit Rosenbrock-W method of
J. Rang and L. Angermann (BIT Numer. Math. 45 (2005) 761-787), in the shared step logic.

A Rosenbrock method replaces the Newton iterations of an implicit Runge-Kutta method by one
linear solve per stage with the matrix I - h gamma W. A *W-method* keeps its order whatever W is
(its order conditions hold for any matrix: E. Hairer and G. Wanner, Solving ODEs II, sec. IV.7,
"W-methods"), so W may be a Jacobian made steps ago, and no df/dt is needed for a
non-autonomous problem (the autonomised system's W may leave the time column out). ROS34PW2 is
a W-method of order 3 with 4 stages, L-stable, with an embedded W-method of order 2 for the
error estimate. Why this one (tests/dynamics/test_implicit.py measures it): with a perturbed or stale
Jacobian and no df/dt it keeps order 3, where ROS3PW (Rang & Angermann's 3-stage method,
R(inf) = 0.73) drops to 2 and RODASP (Steinebach's order-4 Rosenbrock method) to 1; a
Jacobian at every step would cost n evaluations a step, which a W-method saves.

The stages in the transformed variables u_i = sum_j Gamma_ij k_j (Hairer & Wanner, IV.7,
eq. (7.25)-(7.27)), which need no product with W:

    (1/(h gamma) I - W) u_i = f(t + alpha_i h, y + sum_{j<i} a_ij u_j) + sum_{j<i} (c_ij / h) u_j
    y1 = y + sum_i m_i u_i,   error = sum_i (m_i - m^_i) u_i

with a = alpha Gamma^-1, c = diag(1/gamma) - Gamma^-1 (off-diagonal) and m = b Gamma^-1 (Tableau A, G, B; E: m - m^).

The Jacobian: forward differences over the run's compiled evaluation, one per state column.
The state x = [c, v, z] of a Euclidean tree has dc/dt = v exactly: those rows are known
([0, I, 0]), only the rows of a and dz/dt are differenced, and the linear system is reduced to
the (v, z) unknowns by eliminating u_c = (r_c + u_v) / sigma (sigma = 1/(h gamma)): an LU of
size nv + nz instead of 2 nv + nz. Columns of states nothing reads (the drive work meter, the
elements' dissipated energy) are not differenced. A Jacobian is made at a (re)start, after a
step the error test rejected with a Jacobian older than the current state, and when the
secant test after an accepted step finds that it no longer describes the step (|df - J dy| >
|df|: a contact's stiffness grew or vanished under it). The LU is made again for every new step
size (O((nv + nz)^3 / 3), small beside an evaluation): kept across step sizes it would be the
exact matrix of W = J + (sigma - sigma_LU) I, whose extra term grows like 1/h, and the order is
lost (measured on clr_planar_pendulum+A over 0.05 s with a Jacobian kept until a rejection:
the LU kept while the step changed by less than 20 % took 2.5 times the steps of an LU per step
size, and dissipated 366 J where the reference dissipates 7e-4 J).

Step-size control: the standard controller on the error estimate, as the explicit methods
(SciPy's: factor 0.9 err^(-1/3), at most 10, at least 0.2, no growth right after a rejection),
so a run behaves like one of rk.py's. The estimate is the embedded one through Shampine's
filter (error_norm) and, in runs with events, the larger of that and the dense output's own
check (hermite_norm). Dense output: the cubic Hermite interpolant of the step's end values and
derivatives (rk_dense for every kind but RK45/DOP853); its interpolation error, at most
h^4 |y^(4)| / 384, is of the order of the local error of an order-3 method on smooth
solutions. Over the long steps of a stiff problem it is not (a cubic cannot follow a boundary
layer): samples between such steps are less accurate than the step ends; where events are
located on it, hermite_norm holds it to the tolerance.
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.core.errors import InputError
from pinclear.core.jit import njit
from pinclear.dynamics.stepping.base import Method, MethodState
from pinclear.dynamics.stepping.checks import BAD, FAILED, RESELECT, observe
from pinclear.dynamics.stepping.control import ACCEPTED, GO_ON, TOO_SMALL, begin, grown, outcome, propose, shrunk
from pinclear.dynamics.stepping.rk import accept
from pinclear.dynamics.stepping.state import (
    ATOL,
    DX,
    H_ABS,
    NJAC,
    ROSENBROCK,
    RTOL,
    T_BOUND,
    XB,
    Y_NEW,
    YS,
    F,
    T,
    Y,
    tableau,
)
from pinclear.dynamics.stepping.system import evaluate

# --------------------------------------------------------------------------------- coefficients
#: ROS34PW2's coefficients (Rang & Angermann 2005): gamma, alpha_ij, gamma_ij (i > j), b and the
#: embedded b^
_G34 = 4.3586652150845900e-01
ROS34PW2_COEFFS = dict(
    alpha=[[0, 0, 0, 0],
           [8.7173304301691801e-01, 0, 0, 0],
           [8.4457060015369423e-01, -1.1299064236484185e-01, 0, 0],
           [0, 0, 1.0, 0]],
    gamma=[[_G34, 0, 0, 0],
           [-8.7173304301691801e-01, _G34, 0, 0],
           [-9.0338057013044082e-01, 5.4180672388095326e-02, _G34, 0],
           [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, _G34]],
    b=[2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, _G34],
    b_hat=[3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01],
    order=3)


def rosenbrock_tableau(coeffs):
    """The Tableau of a Rosenbrock(-W) method given by alpha, Gamma, b, b^ (Hairer & Wanner's
    notation), in the transformed variables of the module doc: A = alpha Gamma^-1,
    G = c (strictly lower), B = b Gamma^-1, E = (b - b^) Gamma^-1, C = alpha's row sums;
    ``order`` is the embedded estimate's (the step-size exponent is -1 / (order + 1))."""
    al = np.asarray(coeffs["alpha"], float)
    gam = np.asarray(coeffs["gamma"], float)
    gi = np.linalg.inv(gam)
    c = np.tril(-gi, -1)
    return tableau(ROSENBROCK, coeffs["order"] - 1, A=al @ gi, B=np.asarray(coeffs["b"], float) @ gi,
                   C=al.sum(axis=1), E=(np.asarray(coeffs["b"], float) - np.asarray(coeffs["b_hat"], float)) @ gi,
                   G=c, gamma=gam[0, 0])


# --------------------------------------------------------------------------------- the work array
#: scalars of the method, kept at the head of Steps.W (entry k at W[k // n, k % n]): the rows
#: differenced (m = n - p, p the leading rows with dc/dt = v), the Jacobian's state (NONE, FRESH:
#: made at the current state, AGED: made before the last accepted step), its age in accepted
#: steps, the step the LU was made for (0: none), the largest age (inf: no limit), the secant
#: test's tolerance, LU factorisations made, whether the embedded estimate is filtered, whether
#: the dense output is part of the error test, whether the Jacobian has its time column
(M_ROWS, J_STATE, J_AGE, LU_H, MAX_AGE, SECANT, N_LU, FILTER, DENSE_TEST, TIME_COLUMN) = range(10)
NMETA = 10
NONE, FRESH, AGED = 0.0, 1.0, 2.0
#: relative perturbation of the difference quotients (the square root of the unit roundoff
#: balances truncation against cancellation, Dennis & Schnabel, Numerical Methods for
#: Unconstrained Optimization, sec. 5.4)
SQRT_EPS = math.sqrt(np.finfo(float).eps)
#: default policy (benchmarks/bench_implicit.py measured the alternatives)
DEFAULT_MAX_AGE = np.inf
DEFAULT_SECANT = 1.0


def meta_rows(n):
    return -(-NMETA // n)


def work_rows(n, m):
    """Rows of W for a state of n components with m differenced rows: the scalars, the Jacobian
    (m x n), the LU (m x m in m rows), its pivots, the column mask, the time column df/dt (its
    first m entries: the secant test's)."""
    return meta_rows(n) + 2 * m + 3


def work_array(n, p, events, skip=(), max_age=DEFAULT_MAX_AGE, secant=DEFAULT_SECANT, filtered=True, dense=None,
               time_column=False):
    """The method's work array W for a run of n state components of which the first p have
    dc/dt = v (0: none known); ``events``: whether the run locates events (then the dense output
    is in the error test unless ``dense`` says otherwise); ``skip``: state indices nothing depends
    on (their Jacobian columns are zero and not differenced); ``time_column``: make df/dt with
    every Jacobian for the secant test (jacobian)."""
    m = n - p
    W = np.zeros((work_rows(n, m), n))
    flat = W.reshape(-1)
    flat[M_ROWS], flat[J_STATE], flat[MAX_AGE], flat[SECANT], flat[FILTER] = m, NONE, max_age, secant, float(filtered)
    # the dense output is in the error test where events are located on it (dense=None)
    flat[DENSE_TEST] = float(events if dense is None else dense)
    flat[TIME_COLUMN] = float(time_column)
    mask = W[meta_rows(n) + 2 * m + 1]
    mask[:] = 1.0
    mask[list(skip)] = 0.0
    return W


def prepare(st, n, p, **policy):
    """``st`` with its W made for this run (work_array; the events read from st's channels)."""
    return st._replace(W=work_array(n, p, st.G.shape[1] > 0, **policy))


@njit(cache=True, inline="always")
def _get(W, k):
    n = W.shape[1]
    return W[k // n, k % n]


@njit(cache=True, inline="always")
def _set(W, k, value):
    n = W.shape[1]
    W[k // n, k % n] = value


# --------------------------------------------------------------------------------- linear algebra
@njit(cache=True)
def lu_factor(W, r0, m, p, sigma):
    """The LU (partial pivoting) of sigma I - J reduced to the m differenced unknowns (module
    doc): R = sigma I - J_r - J_c / sigma, J_r the Jacobian's columns of those unknowns, J_c its
    columns of the p leading states (whose rates are the first p of them). In W's LU rows, the
    pivots in the row after them. False when singular."""
    L0 = r0 + m
    piv = W[r0 + 2 * m]
    inv = 1.0 / sigma if p else 0.0
    for k in range(m):
        for j in range(m):
            v = -W[r0 + k, p + j]
            if j < p:
                v -= W[r0 + k, j] * inv
            W[L0 + k, j] = v
        W[L0 + k, k] += sigma
    for k in range(m):
        best, ip = abs(W[L0 + k, k]), k
        for i in range(k + 1, m):
            a = abs(W[L0 + i, k])
            if a > best:
                best, ip = a, i
        if not best > 0.0 or not np.isfinite(best):
            return False
        piv[k] = ip
        if ip != k:
            for j in range(m):
                tmp = W[L0 + k, j]
                W[L0 + k, j] = W[L0 + ip, j]
                W[L0 + ip, j] = tmp
        d = 1.0 / W[L0 + k, k]
        for i in range(k + 1, m):
            l = W[L0 + i, k] * d
            W[L0 + i, k] = l
            if l != 0.0:
                for j in range(k + 1, m):
                    W[L0 + i, j] -= l * W[L0 + k, j]
    return True


@njit(cache=True)
def lu_solve(W, r0, m, p, sigma, u):
    """u = (sigma I - J)^-1 u in place, through the reduced system of lu_factor (sigma: the one
    the LU was made with)."""
    L0 = r0 + m
    piv = W[r0 + 2 * m]
    if p:
        inv = 1.0 / sigma
        for k in range(m):
            acc = 0.0
            for i in range(p):
                acc += W[r0 + k, i] * u[i]
            u[p + k] += acc * inv
    for k in range(m):
        ip = int(piv[k])
        if ip != k:
            tmp = u[p + k]
            u[p + k] = u[p + ip]
            u[p + ip] = tmp
    for k in range(m):
        acc = u[p + k]
        for j in range(k):
            acc -= W[L0 + k, j] * u[p + j]
        u[p + k] = acc
    for k in range(m - 1, -1, -1):
        acc = u[p + k]
        for j in range(k + 1, m):
            acc -= W[L0 + k, j] * u[p + j]
        u[p + k] = acc / W[L0 + k, k]
    for i in range(p):
        u[i] = (u[i] + u[p + i]) * (1.0 / sigma)


# --------------------------------------------------------------------------------- the Jacobian
@njit(cache=True)
def jacobian(sys, st, t, r0, m, p):
    """The differenced rows of df/dx at (t, y) by forward differences from f(t, y) = V[F], one
    evaluation per column of the mask (each observed as any other), and df/dt by one more where
    the run asks for it (TIME_COLUMN; otherwise that column stays zero). A bad
    evaluation leaves its column zero: a W-method needs no exact Jacobian. Returns the first
    FAILED or RESELECT verdict (the Jacobian is then incomplete), else GOOD.

    df/dt is not used by the stages (a W-method keeps its order without it), only by the secant
    test (secant_ratio): where f depends on t through the positions, as the manifold
    formulation's projection onto the drives' rows Phi(q, t) = 0 at every evaluation, the motion
    along a driven coordinate is invisible to df/dx at fixed t (the projection pulls the
    coordinate back), and a secant test without df/dt found every Jacobian stale (nine-bar +
    clearance A, manifold + ROS34PW2: 3 056 Jacobians in 3 403 steps, against 463 in 2 368 with
    the projection formulation, whose f depends on t only through the drives' accelerations;
    there the time column made the secant test keep Jacobians longer, and nine-bar + clearance A
    with lagrange at rtol 1e-7 ended 1.0e-6 from the reference instead of 1.2e-7)."""
    V, W, rr, ii = st.V, st.W, st.r, st.i
    y, f, ys, dx, atol, xb = V[Y], V[F], V[YS], V[DX], V[ATOL], V[XB]
    n = y.shape[0]
    rtol = rr[RTOL]
    mask = W[r0 + 2 * m + 1]
    for i in range(n):
        ys[i] = y[i]
    for j in range(n):
        if mask[j] == 0.0:
            for k in range(m):
                W[r0 + k, j] = 0.0
            continue
        typ = atol[j] / rtol if rtol > 0.0 and 0.0 < atol[j] < np.inf else 1.0
        yj = y[j]
        ys[j] = yj + SQRT_EPS * max(abs(yj), typ)
        d = ys[j] - yj                      # the step actually taken (rounded)
        v = observe(rr, ii, xb, evaluate(sys, t, ys, dx), t, ys)
        ys[j] = yj
        if v == FAILED or v == RESELECT:
            return v
        if v == BAD:
            for k in range(m):
                W[r0 + k, j] = 0.0
            continue
        inv = 1.0 / d
        for k in range(m):
            W[r0 + k, j] = (dx[p + k] - f[p + k]) * inv
    if _get(W, TIME_COLUMN) != 0.0:
        ft = W[r0 + 2 * m + 2]
        t1 = t + SQRT_EPS * max(abs(t), abs(rr[H_ABS]))
        d = t1 - t
        v = observe(rr, ii, xb, evaluate(sys, t1, ys, dx), t1, ys)
        if v == FAILED or v == RESELECT:
            return v
        for k in range(m):
            ft[k] = 0.0 if v == BAD or d == 0.0 else (dx[p + k] - f[p + k]) / d
    ii[NJAC] += 1
    return 0


@njit(cache=True)
def hermite_norm(st, h, f_new):
    """The step's dense output checked with it: RMS of (2 (y_new - y) - h (f + f_new)) / 8 over
    the error test's scale, the distance at mid-step between the cubic Hermite interpolant (the
    dense output, pinclear.dynamics.stepping.rk.rk_dense) and the quadratic through y, f and y_new: an
    O(h^3) estimate like the embedded one. The embedded estimate sees f only at the stages, so
    a step whose end lies in a contact the stages barely touched passes it while f there (the
    Hermite's end slope) bends the interpolant over the whole step, and with it the located
    event's state; explicit methods with f at the new point in their estimate (RK45) see it."""
    V, rtol = st.V, st.r[RTOL]
    y, y_new, f, atol = V[Y], V[Y_NEW], V[F], V[ATOL]
    n = y.shape[0]
    acc = 0.0
    for i in range(n):
        d = 0.125 * (2.0 * (y_new[i] - y[i]) - h * (f[i] + f_new[i]))
        v = d / (atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol)
        acc += v * v
    return (acc / n) ** 0.5 if n else 0.0


@njit(cache=True)
def secant_ratio(st, r0, m, p, h):
    """How far the Jacobian is from the step just taken: |df - J dy - f_t h| / |df| over the
    differenced rows (dy = y_new - y, df = f_new - f, f_t the time column made with J, weighted
    by the error test's scale). Near zero while J describes the motion (O(h) on a smooth
    problem); near one when the dynamics changed under it (a contact's stiffness grew, an
    impact): then a new Jacobian."""
    V, W, K, rtol = st.V, st.W, st.K, st.r[RTOL]
    y, y_new, f, atol = V[Y], V[Y_NEW], V[F], V[ATOL]
    f_new = K[K.shape[0] - 2]
    ft = W[r0 + 2 * m + 2]
    n = y.shape[0]
    num = den = 0.0
    for k in range(m):
        i = p + k
        if not atol[i] < np.inf:
            continue
        w = 1.0 / (atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol)
        acc = ft[k] * h
        for j in range(n):
            acc += W[r0 + k, j] * (y_new[j] - y[j])
        df = f_new[i] - f[i]
        num += ((df - acc) * w) ** 2
        den += (df * w) ** 2
    return (num / den) ** 0.5 if den > 0.0 else 0.0


# --------------------------------------------------------------------------------- one step
@njit(cache=True)
def _stages(sys, tab, st, t, h, r0, m, p, sigma):
    """The stages u_1..u_s (K[0..s-1]) and the proposed state V[Y_NEW]; the first verdict that
    is not GOOD stops them."""
    K, V, rr, ii, W = st.K, st.V, st.r, st.i, st.W
    A, G, C, B = tab.A, tab.G, tab.C, tab.B
    y, ys, y_new, f, xb = V[Y], V[YS], V[Y_NEW], V[F], V[XB]
    n, ns = y.shape[0], B.shape[0]
    hinv = 1.0 / h
    for s in range(ns):
        u = K[s]
        if s == 0:
            for i in range(n):
                u[i] = f[i]
        else:
            for i in range(n):
                acc = 0.0
                for j in range(s):
                    acc += A[s, j] * K[j, i]
                ys[i] = y[i] + acc
            ts = t + C[s] * h
            v = observe(rr, ii, xb, evaluate(sys, ts, ys, u), ts, ys)
            if v != 0:
                return v
            for i in range(n):
                acc = 0.0
                for j in range(s):
                    acc += G[s, j] * K[j, i]
                u[i] += acc * hinv
        lu_solve(W, r0, m, p, sigma, u)
    for i in range(n):
        acc = 0.0
        for j in range(ns):
            acc += B[j] * K[j, i]
        y_new[i] = y[i] + acc
    return 0


@njit(cache=True)
def error_norm(tab, st, r0, m, p, sigma, filtered):
    """RMS of the embedded estimate sum_j E_j u_j over atol + max(|y|, |y_new|) rtol (SciPy's
    norm, as the explicit methods). ``filtered``: the estimate multiplied by (I - h gamma W)^-1
    first (Shampine's filter, Hairer & Wanner, Solving ODEs II, sec. IV.8, eq. (8.20)): the
    embedded method of ROS34PW2 is not L-stable (|R^(inf)| = 0.48), so without it a stiff
    component the main method damps correctly keeps the estimate at about half its size
    whatever the step, and the steps collapse in stiff contact; the filter leaves the
    non-stiff components' estimate as it is (to O(h))."""
    K, V, rtol = st.K, st.V, st.r[RTOL]
    y, y_new, atol, E = V[Y], V[Y_NEW], V[ATOL], tab.E
    n, ns = y.shape[0], E.shape[0]
    e = K[ns + 1]
    for i in range(n):
        acc = 0.0
        for j in range(ns):
            acc += E[j] * K[j, i]
        e[i] = acc
    if filtered:
        lu_solve(st.W, r0, m, p, sigma, e)
        for i in range(n):
            e[i] *= sigma
    acc = 0.0
    for i in range(n):
        v = e[i] / (atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol)
        acc += v * v
    return (acc / n) ** 0.5 if n else 0.0


@njit(cache=True)
def fresh_jacobian(sys, st, t, r0, m, p):
    """A new Jacobian at the step's start (t, y), W's factor to be redone: GO_ON, or the step's
    outcome (pinclear.dynamics.stepping.control.outcome) when one of its evaluations failed or asked for
    other constraint rows; the incomplete Jacobian is then marked NONE (computed again)."""
    W = st.W
    o = outcome(jacobian(sys, st, t, r0, m, p), st.r, st.i)
    if o != GO_ON:
        _set(W, J_STATE, NONE)
        return o
    _set(W, J_STATE, FRESH)
    _set(W, J_AGE, 0.0)
    _set(W, LU_H, 0.0)
    return GO_ON


@njit(cache=True)
def rosenbrock_step(sys, tab, st):
    """One accepted step from (t, y, f) with the conventions of rk.rk_step: TOO_SMALL,
    BAD_EVALS (more than MAX_BAD bad evaluations in a row), ASK_RESELECT (nothing changed; the
    step is redone after), STAGE_ERROR. A bad evaluation (trial stage, the proposed state's f)
    rejects the attempt like an error norm above one (the step shrinks by 5); a rejection by
    the error test with a Jacobian older than the current state computes it again there
    first. f at the accepted state (K[s]) is the next step's first stage and the dense
    output's end slope."""
    r, ii, V, K, W = st.r, st.i, st.V, st.K, st.W
    ns = tab.B.shape[0]
    n = V.shape[1]
    r0 = -(-NMETA // n)
    m = int(_get(W, M_ROWS))
    p = n - m
    t, t_bound = r[T], r[T_BOUND]
    min_step, h_abs, expo = begin(r, tab.order)
    gamma = tab.gamma
    rejected = False
    if _get(W, J_STATE) == NONE:
        o = fresh_jacobian(sys, st, t, r0, m, p)
        if o != GO_ON:
            return o
    while True:
        if h_abs < min_step:
            r[H_ABS] = h_abs
            return TOO_SMALL
        t_new, h, h_abs = propose(t, h_abs, t_bound)
        h_lu = _get(W, LU_H)
        if h_lu != h:
            _set(W, N_LU, _get(W, N_LU) + 1.0)
            if lu_factor(W, r0, m, p, 1.0 / (h * gamma)):
                h_lu = h
            else:
                h_lu = 0.0                  # sigma is an eigenvalue of J: another step size
            _set(W, LU_H, h_lu)
        v = BAD if h_lu == 0.0 else _stages(sys, tab, st, t, h, r0, m, p, 1.0 / (h_lu * gamma))
        o = outcome(v, r, ii)
        if o != GO_ON:
            return o
        err = np.nan
        if v != BAD:
            err = error_norm(tab, st, r0, m, p, 1.0 / (h_lu * gamma), _get(W, FILTER) != 0.0)
            if err < 1.0:
                y_new, f_new = V[Y_NEW], K[ns]
                v = observe(r, ii, V[XB], evaluate(sys, t_new, y_new, f_new), t_new, y_new)
                o = outcome(v, r, ii)
                if o != GO_ON:
                    return o
                if v == BAD:
                    err = np.nan
                elif _get(W, DENSE_TEST) != 0.0:
                    err = max(err, hermite_norm(st, h, f_new))
                if err < 1.0:
                    age = _get(W, J_AGE) + 1.0
                    _set(W, J_AGE, age)
                    stale = age >= _get(W, MAX_AGE) or secant_ratio(st, r0, m, p, h) > _get(W, SECANT)
                    _set(W, J_STATE, NONE if stale else AGED)
                    accept(V, r, ii, f_new, t_new, h, h_abs * grown(err, expo, rejected))
                    return ACCEPTED
        h_abs = shrunk(h_abs, err, expo, ii)
        rejected = True
        if err == err and _get(W, J_STATE) != FRESH:
            # rejected by the error test with a Jacobian of an earlier state: W may be what failed
            o = fresh_jacobian(sys, st, t, r0, m, p)
            if o != GO_ON:
                return o


# --------------------------------------------------------------------------------- the method
class Rosenbrock(Method):
    """A Rosenbrock(-W) method of the compiled step logic (module doc); ``coeffs`` as
    ROS34PW2_COEFFS. ``max_age`` and ``secant`` set the Jacobian's reuse (a method that is not a
    W-method needs max_age=1), ``filtered`` and ``dense`` the error estimate (prepare)."""

    corrects_state = True

    def __init__(self, name, coeffs, max_age=DEFAULT_MAX_AGE, secant=DEFAULT_SECANT, filtered=True, dense=None):
        self.name, self.coeffs = name, coeffs
        self.max_age, self.secant, self.filtered, self.dense = max_age, secant, filtered, dense
        # K: the stages, f at the proposed state, the error estimate
        self.rows = len(coeffs["b"]) + 2

    def setup(self, run):
        mech, n = run.mech, run.st.V.shape[1]
        # the chart rate of a non-Euclidean tree depends on c and v: every row is differenced
        p = run.nc if mech.euclidean else 0
        skip = []
        base = run.nc + mech.nv
        if mech.n_work:
            skip.append(base + mech.z_work.start)
        for f, sl in zip(mech.forces, mech.z_slices):
            if f.dissipation_state is not None:
                skip.append(base + sl.start + f.dissipation_state)
        # W's size depends on the run's state
        W = work_array(n, p, run.st.G.shape[1] > 0, skip, self.max_age, self.secant, self.filtered, self.dense,
                       run.form.time_in_positions)
        return MethodState(self.tableau(run), W)

    def tableau(self, run):
        return rosenbrock_tableau(self.coeffs)

    def restart(self, own, st, t, x, hint):
        # an event changed the dynamics (an impact starts a contact): a new Jacobian (keeping the
        # old one was measured no cheaper on the bundled clearance scenes)
        own.W.reshape(-1)[J_STATE] = NONE

    def stats(self, own, st):
        return {"jacobians": int(st.i[NJAC]), "lu_decompositions": int(own.W.reshape(-1)[N_LU])}

    def saved_state(self, own):
        """The Jacobian (its rows, its time column, whether it was made at the current state and
        its age), reused across steps, so a resumed run takes the same steps. The LU is not kept: it is made again from the
        same matrix and step size, which gives the same factors."""
        W = own.W
        flat, n = W.reshape(-1), W.shape[1]
        r0, m = meta_rows(n), int(flat[M_ROWS])
        return {"jacobian": W[r0:r0 + m].copy(), "time_column": W[r0 + 2 * m + 2].copy(),
                "flags": np.array([flat[J_STATE], flat[J_AGE]])}

    def check_saved_state(self, own, state, path):
        j_state, age = (float(x) for x in state["flags"])
        if j_state not in (NONE, FRESH, AGED) or age < 0:
            raise InputError(f"{path}: the saved Jacobian state {j_state!r} / age {age!r} is not one this method "
                             "writes")
        return state

    def restore_state(self, own, state):
        j_state, age = (float(x) for x in state["flags"])
        W = own.W
        flat, n = W.reshape(-1), W.shape[1]
        r0, m = meta_rows(n), int(flat[M_ROWS])
        W[r0:r0 + m] = state["jacobian"]
        W[r0 + 2 * m + 2] = state["time_column"]
        flat[J_STATE], flat[J_AGE], flat[LU_H] = j_state, age, 0.0


#: the registered implicit method (pinclear.core.registry.INTEGRATORS)
ROS34PW2 = Rosenbrock("ROS34PW2", ROS34PW2_COEFFS)
