"""SciPy's implicit integrators (Radau, BDF, LSODA) in the run's step logic: SciPy takes each
step in Python (its Newton iterations, its finite-difference Jacobian over the compiled
right-hand side), through a callback of the compiled chunk, which does everything after the step
as for every other method (events, samples, projection, the monitor, the stall test).

They stay for comparison and for users who know them; pinclear's own implicit method
(pinclear.dynamics.stepping.rosenbrock) runs compiled and is the one to use for stiff contact.
"""
from __future__ import annotations

import numpy as np
from scipy import integrate as spi

from pinclear.core.call import NONFINITE
from pinclear.core.stage import python_stage
from pinclear.dynamics.stepping.base import Method, MethodState
from pinclear.dynamics.stepping.checks import GOOD, observe
from pinclear.dynamics.stepping.control import ACCEPTED, BAD_EVALS, MAX_BAD, TOO_SMALL
from pinclear.dynamics.stepping.state import (
    ATOL,
    BAD,
    EXTERNAL,
    H_ABS,
    H_PREV,
    MAX_STEP,
    RTOL,
    T_BOUND,
    T_OLD,
    XB,
    XE,
    F,
    T,
    Y,
    tableau,
)
from pinclear.dynamics.stepping.system import evaluate


class _Bad(Exception):
    """A bad evaluation inside SciPy's step (recorded by observe): the step stops there."""


class _Driver:
    """The callbacks of one run's SciPy solver (step, dense output, reset after a projection)."""

    def __init__(self, method, run):
        self.method, self.run, self.solver, self.dense = method, run, None, None
        self.message = ""            # SciPy's message when a step failed (the run's failure reads it)
        # the compiled chunk calls these back (kept alive with the driver for the run)
        self.stages = [python_stage(f, run.errors, name=f"{method.name} {f.__name__}")
                       for f in (self.step, self.dense_at, self.reset)]

    def fun(self, t, y):
        run = self.run
        y = np.ascontiguousarray(y, float)
        dx = np.empty(len(y))
        code = evaluate(run.system, float(t), y, dx)
        v = observe(run.st.r, run.st.i, run.st.V[XB], code, float(t), y)
        # an overflow is SciPy's to handle (its Newton iteration fails and the step shrinks) until
        # it keeps happening; a rank loss or a failed Python stage ends the step at once
        if v != GOOD and not (code == NONFINITE and run.st.i[BAD] <= MAX_BAD):
            raise _Bad(v)
        return dx

    def restart(self, t, x, hint):
        st = self.run.st
        kw = {"rtol": st.r[RTOL], "atol": st.V[ATOL].copy()}
        if np.isfinite(st.r[MAX_STEP]):
            kw["max_step"] = st.r[MAX_STEP]
        if hint is not None:
            kw["first_step"] = min(hint, st.r[T_BOUND] - t)
        self.solver = self.method.cls(self.fun, t, x, st.r[T_BOUND], **kw)
        self.dense = None

    def step(self, t):
        st, solver = self.run.st, self.solver
        try:
            msg = solver.step()
        except _Bad:
            return float(BAD_EVALS)
        if solver.status == "failed":
            self.message = msg
            return float(TOO_SMALL)
        st.V[Y] = solver.y
        st.r[T_OLD], st.r[T] = solver.t_old, solver.t
        st.r[H_PREV] = solver.t - solver.t_old
        st.r[H_ABS] = vars(solver).get("h_abs", solver.step_size or 0.0)
        self.dense = None
        return float(ACCEPTED)

    def dense_at(self, t):
        if self.dense is None:
            self.dense = self.solver.dense_output()
        self.run.st.V[XE] = self.dense(t)
        return 0.0

    def reset(self, t):
        """The projected state (V[Y], V[F]) goes into the solver."""
        st, solver = self.run.st, self.solver
        self.method.reset_state(solver, st.V[Y].copy(), st.V[F].copy())
        return 0.0


class Scipy(Method):
    python_steps = True

    def __init__(self, name, cls, corrects_state=True):
        self.name, self.cls, self.corrects_state = name, cls, corrects_state

    def setup(self, run):
        driver = _Driver(self, run)
        tab = tableau(EXTERNAL, 0, ext=[s.fn for s in driver.stages])
        return MethodState(tab, np.zeros((0, run.st.V.shape[1])), driver)

    def tableau(self, run):
        return self.setup(run).tab

    def restart(self, own, st, t, x, hint):
        own.driver.restart(float(t), np.array(x, float), hint)      # SciPy chooses the first step

    def reset_state(self, solver, y, f):
        solver.y = y
        solver.f = f


class _BDF(Scipy):
    def reset_state(self, solver, y, f):
        solver.y = y
        solver.D[0] = y


#: the registered SciPy methods (pinclear.core.registry.INTEGRATORS); any other OdeSolver subclass
#: (its _step_impl and _dense_output_impl) joins the same way
RADAU = Scipy("Radau", spi.Radau)
BDF = _BDF("BDF", spi.BDF)
#: LSODA keeps an internal history that a corrected state cannot enter
LSODA = Scipy("LSODA", spi.LSODA, corrects_state=False)
