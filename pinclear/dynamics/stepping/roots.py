"""Brent's methods in reverse communication (the caller evaluates the function): the minimiser
that searches a step for a singular passage and the root finder that locates an event crossing.
Reverse communication lets one search serve every caller: the compiled step logic evaluates the
dense output and the stages in compiled code; a Python caller may evaluate anything it likes,
at the same points."""
from __future__ import annotations

import math

import numpy as np

from pinclear.core.jit import njit

#: Brent's golden-section ratio (3 - sqrt 5) / 2
_GOLDEN = 0.5 * (3.0 - math.sqrt(5.0))
#: the search state of brent_start / brent_next: the bracket [a, b], the three best points
#: x <= w <= v (by value), the last two moves d, e, the trial point u, its count, the tolerance
_A, _B, _V, _W, _X, _FV, _FW, _FX, _D, _E, _U, _N, _XATOL = range(13)
BRENT_STATE = 13


@njit(cache=True)
def brent_start(a, b, xatol, st):
    """Start Brent's minimisation of f on [a, b] (golden sections, parabolic steps where the
    last three points trust them; R. P. Brent, Algorithms for Minimization without
    Derivatives, 1973, ch. 5), to within sqrt(eps)|x| + xatol/3. Returns the first point to
    evaluate; give f there to :func:`brent_next`.

    Reverse communication (the caller evaluates f) lets one search serve every caller
    (the module doc)."""
    st[_A], st[_B], st[_XATOL] = a, b, xatol
    x = a + _GOLDEN * (b - a)
    st[_V] = st[_W] = st[_X] = st[_U] = x
    st[_D] = st[_E] = st[_N] = 0.0
    return x


@njit(cache=True)
def brent_next(st, fu, maxiter):
    """Take f at the point brent_start or the last brent_next returned; returns (the next point
    to evaluate, False), or (the minimiser found, True) once the bracket is within tolerance or
    ``maxiter`` points were evaluated (its value is st[_FX])."""
    a, b, v, w, x = st[_A], st[_B], st[_V], st[_W], st[_X]
    fv, fw, fx, d, e, u = st[_FV], st[_FW], st[_FX], st[_D], st[_E], st[_U]
    n = st[_N] + 1.0
    if n == 1.0:
        fv = fw = fx = fu
    elif fu <= fx:
        if u < x:
            b = x
        else:
            a = x
        v, fv, w, fw, x, fx = w, fw, x, fx, u, fu
    else:
        if u < x:
            a = u
        else:
            b = u
        if fu <= fw or w == x:
            v, fv, w, fw = w, fw, u, fu
        elif fu <= fv or v == x or v == w:
            v, fv = u, fu
    mid = 0.5 * (a + b)
    tol = math.sqrt(np.finfo(np.float64).eps) * abs(x) + st[_XATOL] / 3.0
    done = abs(x - mid) <= 2.0 * tol - 0.5 * (b - a) or n >= maxiter
    if not done:
        parabolic = False
        if abs(e) > tol:
            # the parabola through (v, fv), (w, fw), (x, fx); its vertex is x + p / q
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            else:
                q = -q
            e_prev, e = e, d
            # accept it inside the bracket and when it moves less than half the step before last
            if abs(p) < abs(0.5 * q * e_prev) and q * (a - x) < p < q * (b - x):
                parabolic = True
                d = p / q
                if (x + d) - a < 2.0 * tol or b - (x + d) < 2.0 * tol:
                    d = tol if x < mid else -tol
        if not parabolic:
            e = (b - x) if x < mid else (a - x)
            d = _GOLDEN * e
        u = x + (d if abs(d) >= tol else (tol if d > 0.0 else -tol))
    st[_A], st[_B], st[_V], st[_W], st[_X] = a, b, v, w, x
    st[_FV], st[_FW], st[_FX], st[_D], st[_E], st[_U], st[_N] = fv, fw, fx, d, e, u, n
    return (x if done else u), done


#: the root finder's state (brent_root_start / brent_root_next): the bracket [a, b] with values
#: (fa, fb), the previous point c and value fc, the last two moves d, e, the tolerances, the count
_RA, _RB, _RC, _RFA, _RFB, _RFC, _RD, _RE, _RXT, _RRT, _RN = range(11)
ROOT_STATE = 11


@njit(cache=True)
def brent_root_start(a, b, fa, fb, xtol, rtol, st):
    """Start Brent's root finding (R. P. Brent, Algorithms for Minimization without Derivatives,
    1973, ch. 4: bisection, secant and inverse quadratic interpolation, never slower than
    bisection) on [a, b] with f(a) = fa, f(b) = fb of opposite signs (or one zero), to within
    xtol + rtol |x|. Returns (x, done): the first point to evaluate, or the root when an end is one."""
    st[_RXT], st[_RRT], st[_RN] = xtol, rtol, 0.0
    if fa == 0.0:
        return a, True
    if fb == 0.0:
        return b, True
    st[_RA], st[_RB], st[_RFA], st[_RFB] = a, b, fa, fb
    st[_RC], st[_RFC] = a, fa
    st[_RD] = st[_RE] = b - a
    return _root_propose(st)


@njit(cache=True)
def _root_propose(st):
    """The next point from the bracket in st (b the best so far); (b, True) when converged."""
    a, b, c, fa, fb, fc = st[_RA], st[_RB], st[_RC], st[_RFA], st[_RFB], st[_RFC]
    d, e = st[_RD], st[_RE]
    if (fb > 0.0) == (fc > 0.0):          # keep the root between b and c
        c, fc = a, fa
        d = e = b - a
    if abs(fc) < abs(fb):                 # b the better end
        a, b, c = b, c, b
        fa, fb, fc = fb, fc, fb
    tol = 2.0 * np.finfo(np.float64).eps * abs(b) + 0.5 * (st[_RXT] + st[_RRT] * abs(b))
    m = 0.5 * (c - b)
    if abs(m) <= tol or fb == 0.0:
        st[_RA], st[_RB], st[_RC], st[_RFA], st[_RFB], st[_RFC] = a, b, c, fa, fb, fc
        return b, True
    if abs(e) < tol or abs(fa) <= abs(fb):
        d = e = m                         # bisection
    else:
        s = fb / fa
        if a == c:                        # secant
            p, q = 2.0 * m * s, 1.0 - s
        else:                             # inverse quadratic interpolation
            qq, r = fa / fc, fb / fc
            p = s * (2.0 * m * qq * (qq - r) - (b - a) * (r - 1.0))
            q = (qq - 1.0) * (r - 1.0) * (s - 1.0)
        if p > 0.0:
            q = -q
        else:
            p = -p
        if 2.0 * p < min(3.0 * m * q - abs(tol * q), abs(e * q)):
            e, d = d, p / q
        else:
            d = e = m
    a, fa = b, fb
    b = b + (d if abs(d) > tol else (tol if m > 0.0 else -tol))
    st[_RA], st[_RB], st[_RC], st[_RFA], st[_RFC], st[_RD], st[_RE] = a, b, c, fa, fc, d, e
    return b, False


@njit(cache=True)
def brent_root_next(st, fb, maxiter):
    """Take f at the point last returned; returns (the next point, False) or (the root, True)
    once the bracket is within tolerance or ``maxiter`` points were evaluated."""
    st[_RFB] = fb
    st[_RN] += 1.0
    x, done = _root_propose(st)
    if not done and st[_RN] >= maxiter:
        return st[_RB] if abs(st[_RFB]) <= abs(st[_RFC]) else st[_RC], True
    return x, done
