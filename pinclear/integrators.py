"""Time integrators by name, behind one small contract: SciPy's OdeSolvers (RK45, DOP853,
Radau, BDF, LSODA) and a fixed-step classical Runge-Kutta 4 in the same interface."""
from __future__ import annotations

import abc
import inspect
import warnings

import numpy as np
from scipy import integrate as spi
from scipy.integrate._ivp.common import select_initial_step

from ._jit import njit
from .errors import InputError

EPS = np.finfo(float).eps
_INITIAL_STEP_BOUNDED = "t_bound" in inspect.signature(select_initial_step).parameters


class Integrator(abc.ABC):
    """How the simulator obtains and steers an ODE solver.

    The contract:

    1. ``name`` is the user-facing name; ``adaptive`` says whether it takes rtol/atol (error
       control) or a fixed step ``h``; giving the other kind of option is an InputError.
    2. :meth:`start` returns a SciPy ``OdeSolver`` (``step()``, ``t``, ``y``, ``status``,
       ``step_size``, ``dense_output()``) over ``fun(t, y)`` from (t0, y0) to ``t_bound``.
    3. ``corrects_state`` says whether a state changed between steps (projection) can be put
       into the running solver with :meth:`reset_state`; if not, the simulator restarts it.
    4. ``rejects_nonfinite`` says whether a NaN right-hand side at a trial stage makes the solver
       reject the step and retry smaller (explicit embedded Runge-Kutta pairs). Implicit solvers
       carry it into their Newton iteration and Jacobian, and a fixed step cannot be retried, so
       for them a failed evaluation (rank loss) ends the run at once.
    """

    name = ""
    adaptive = True
    corrects_state = True
    rejects_nonfinite = False

    @abc.abstractmethod
    def start(self, fun, t0, y0, t_bound, *, rtol, atol, max_step, first_step, h):
        """A fresh solver."""

    def reset_state(self, solver, fun, x, t):
        """Put a corrected state x at time t into a running solver."""
        solver.y = x
        solver.f = fun(t, x)

    def check_options(self, *, h=None, max_step=None, first_step=None):
        if self.adaptive and h is not None:
            raise InputError(f"integrator {self.name!r} is adaptive (rtol/atol): the fixed step h "
                             "applies only to 'RK4'")
        if not self.adaptive:
            if h is None:
                raise InputError(f"integrator {self.name!r} is fixed-step: give h (seconds)")
            if max_step is not None and np.isfinite(max_step):
                raise InputError(f"integrator {self.name!r} is fixed-step: max_step does not apply (give h)")
            if first_step is not None:
                raise InputError(f"integrator {self.name!r} is fixed-step: first_step does not apply (give h)")


class ScipyIntegrator(Integrator):
    def __init__(self, name, cls, corrects_state=True, rejects_nonfinite=False):
        self.name, self.cls, self.corrects_state = name, cls, corrects_state
        self.rejects_nonfinite = rejects_nonfinite

    def start(self, fun, t0, y0, t_bound, *, rtol, atol, max_step, first_step, h):
        kw = {}
        if max_step is not None and np.isfinite(max_step):
            kw["max_step"] = max_step
        if first_step is not None:
            kw["first_step"] = min(first_step, t_bound - t0)
        return self.cls(fun, t0, y0, t_bound, rtol=rtol, atol=atol, **kw)


@njit(cache=True)
def _rk_stage(y, K, a, s, h, out):
    """out = y + (sum_{j<s} a_j K_j) h: the state of Runge-Kutta stage s."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += K[j, i] * a[j]
        out[i] = y[i] + acc * h


@njit(cache=True)
def _rk_error_norm(y, y_new, K, E, h, atol, rtol):
    """RMS over the components of (sum_j E_j K_j) h / (atol + max(|y|, |y_new|) rtol)."""
    acc = 0.0
    for i in range(y.shape[0]):
        e = 0.0
        for j in range(K.shape[0]):
            e += K[j, i] * E[j]
        e = e * h / (atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol)
        acc += e * e
    return (acc / y.shape[0]) ** 0.5


class CompiledRK45(spi.RK45):
    """SciPy's RK45 (Dormand-Prince 5(4), the same tableau, error norm and step-size control,
    its dense output) with the per-step vector arithmetic in two compiled calls and the
    right-hand side called directly. SciPy's step costs ~0.1 ms of Python and NumPy calls on top
    of the six evaluations, as much as the evaluations of a small tree; here it is a few
    microseconds. Its start sets SciPy's attributes without SciPy's argument checks and
    wrappers (~30 us per start, paid again after every impact; simulate has checked the inputs)
    and takes SciPy's initial step. Results equal SciPy's up to the summation order of the stage
    sums."""

    def __init__(self, fun, t0, y0, t_bound, *, rtol, atol, max_step=np.inf, first_step=None):
        # the attributes SciPy's OdeSolver and RungeKutta set (tests/test_compiled.py checks
        # that none is missing)
        self.t_old, self.t, self.t_bound, self.y = None, float(t0), float(t_bound), np.array(y0, float)
        self.n = self.y.size
        self.vectorized, self.status = False, "running"
        self.direction = 1.0 if t_bound >= t0 else -1.0
        self.nfev, self.njev, self.nlu = 0, 0, 0
        self._rhs = self._fun = self.fun_single = fun     # fun returns float arrays
        self.y_old, self.h_previous = None, None
        self.max_step = float(max_step)
        if not np.isfinite(self.y).all():
            raise ValueError("All components of the initial state `y0` must be finite.")
        if rtol < 100 * EPS:          # as SciPy: a tighter rtol only stalls the steps
            warnings.warn(f"rtol {rtol:g} is below 100 eps: using {100 * EPS:g}", RuntimeWarning, stacklevel=3)
            rtol = 100 * EPS
        self.rtol, self.atol = rtol, atol
        self._atol = np.ascontiguousarray(np.broadcast_to(np.asarray(atol, float), (self.n,)))
        self._A = self._A_CONTIGUOUS
        self.K = np.empty((self.n_stages + 1, self.n))
        self.error_exponent = -1 / (self.error_estimator_order + 1)
        self.f = self.fun(self.t, self.y)
        if first_step is not None:
            self.h_abs = float(first_step)
        else:
            self.h_abs = self._initial_step()

    _A_CONTIGUOUS = np.ascontiguousarray(spi.RK45.A, float)

    def fun(self, t, y):
        self.nfev += 1
        return self._rhs(t, y)

    def fun_vectorized(self, t, y):
        return np.stack([self._rhs(t, yi) for yi in y.T], axis=1)

    def _initial_step(self):
        """SciPy's own initial-step selection (Hairer, Norsett and Wanner, Solving ODEs I, II.4),
        so that runs take SciPy's steps bit for bit: in a chattering contact a 1e-12 change of
        the step chosen after an impact changes the later impacts (three_upru_up+P_UP: 888
        instead of 2079 in 0.5 s)."""
        if _INITIAL_STEP_BOUNDED:        # newer SciPy bounds it by the span and max_step
            return select_initial_step(self.fun, self.t, self.y, self.t_bound, self.max_step, self.f,
                                       self.direction, self.error_estimator_order, self.rtol, self.atol)
        return select_initial_step(self.fun, self.t, self.y, self.f, self.direction, self.error_estimator_order,
                                   self.rtol, self.atol)

    def _step_impl(self):
        t, y = self.t, self.y
        max_step, rtol = self.max_step, self.rtol
        min_step = 10 * abs(np.nextafter(t, self.direction * np.inf) - t)
        if self.h_abs > max_step:
            h_abs = max_step
        elif self.h_abs < min_step:
            h_abs = min_step
        else:
            h_abs = self.h_abs
        K, A, C, fun = self.K, self._A, self.C, self._rhs
        ns = self.n_stages
        accepted = rejected = False
        while not accepted:
            if h_abs < min_step:
                return False, self.TOO_SMALL_STEP
            t_new = t + h_abs * self.direction
            if self.direction * (t_new - self.t_bound) > 0:
                t_new = self.t_bound
            h = t_new - t
            h_abs = abs(h)
            K[0] = self.f
            for s in range(1, ns):
                ys = np.empty_like(y)        # a fresh array per stage, as SciPy passes
                _rk_stage(y, K, A[s], s, h, ys)
                K[s] = fun(t + C[s] * h, ys)
            y_new = np.empty_like(y)
            _rk_stage(y, K, self.B, ns, h, y_new)
            f_new = fun(t + h, y_new)
            K[-1] = f_new
            err = _rk_error_norm(y, y_new, K, self.E, h, self._atol, rtol)
            if err < 1:
                factor = 10.0 if err == 0 else min(10.0, 0.9 * err ** self.error_exponent)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                accepted = True
            else:
                h_abs *= max(0.2, 0.9 * err ** self.error_exponent)
                rejected = True
        self.h_previous = h
        self.y_old = y
        self.t, self.y, self.h_abs, self.f = t_new, y_new, h_abs, f_new
        return True, None


class _BDF(ScipyIntegrator):
    def reset_state(self, solver, fun, x, t):
        solver.y = x
        solver.D[0] = x


class _HermiteDense(spi.DenseOutput):
    """Cubic Hermite interpolant over one step (for the fixed-step RK4)."""

    def __init__(self, t0, t1, y0, y1, f0, f1):
        super().__init__(t0, t1)
        self.h, self.y0, self.y1, self.f0, self.f1 = t1 - t0, y0, y1, f0, f1

    def _call_impl(self, t):
        s = (np.asarray(t) - self.t_old) / self.h
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        return (np.multiply.outer(self.y0, h00) + np.multiply.outer(self.f0 * self.h, h10)
                + np.multiply.outer(self.y1, h01) + np.multiply.outer(self.f1 * self.h, h11))


class RK4Solver(spi.OdeSolver):
    """Classical fixed-step Runge-Kutta 4 in SciPy's OdeSolver interface."""

    def __init__(self, fun, t0, y0, t_bound, h=1e-3, vectorized=False, **_):
        super().__init__(fun, t0, y0, t_bound, vectorized)
        if not h or h <= 0:
            raise InputError(f"RK4 needs a positive step h, got {h!r}")
        self.h_fixed = float(h)
        self.f = self.fun(self.t, self.y)
        self._prev = None

    def _step_impl(self):
        t, y, h = self.t, self.y, min(self.h_fixed, abs(self.t_bound - self.t))
        k1 = self.f
        k2 = self.fun(t + h / 2, y + h / 2 * k1)
        k3 = self.fun(t + h / 2, y + h / 2 * k2)
        k4 = self.fun(t + h, y + h * k3)
        y1 = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        f1 = self.fun(t + h, y1)
        self._prev = (t, t + h, y, y1, k1, f1)
        self.t, self.y, self.f = t + h, y1, f1
        return True, None

    def _dense_output_impl(self):
        return _HermiteDense(*self._prev)


class RK4(Integrator):
    name = "RK4"
    adaptive = False

    def start(self, fun, t0, y0, t_bound, *, rtol, atol, max_step, first_step, h):
        return RK4Solver(fun, t0, y0, t_bound, h=h)


INTEGRATORS = {
    "RK45": ScipyIntegrator("RK45", CompiledRK45, rejects_nonfinite=True),
    "DOP853": ScipyIntegrator("DOP853", spi.DOP853, rejects_nonfinite=True),
    "Radau": ScipyIntegrator("Radau", spi.Radau),
    "BDF": _BDF("BDF", spi.BDF),
    # LSODA keeps an internal history that a corrected state cannot enter
    "LSODA": ScipyIntegrator("LSODA", spi.LSODA, corrects_state=False),
    "RK4": RK4(),
}


def get(name) -> Integrator:
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise InputError(f"unknown integrator {name!r}", choices=INTEGRATORS) from None
