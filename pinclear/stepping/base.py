"""One small base class for the integrators, chosen by name (after SciPy's integrate/_ivp: one
method per file, pinclear.stepping.rk, .rosenbrock, .external)."""
from __future__ import annotations

import abc

import numpy as np

from ..errors import InputError


class Method(abc.ABC):
    """How a run integrates. The contract (the run relies on nothing else):

    1. ``name`` is the user-facing name; ``adaptive`` says whether it takes rtol/atol (error
       control) or a fixed step ``h``; giving the other kind of option is an InputError
       (:meth:`check_options`).
    2. :meth:`tableau` returns its coefficients (pinclear.stepping.state.Tableau) for the
       compiled step logic, which takes its steps (pinclear.stepping.chunk.step dispatches on
       the tableau's kind) and shares everything after a step with every other method; ``rows``
       and ``work`` are the rows of the stage array K and of the work array W it needs.
    3. :meth:`start` (re)starts the integration at (t, x) (after an event, a new chart anchor);
       by default the compiled start (f there, SciPy's initial step unless a hint is given).
    4. ``corrects_state`` says whether a state changed after a step (projection) can be put into
       its running state; if not, projection methods cannot use it.
    5. :meth:`stats` adds the method's own counters to a run's stats (Jacobians, LU).
    6. ``python_steps`` says whether its steps are taken in Python (SciPy's solvers), which a
       run's ``stats["loop"]`` reports.
    7. :meth:`setup` gives the method's own state its place in the run's step state before the
       first step (the Rosenbrock method sizes the work array W for the run's state).
    """

    name = ""
    adaptive = True
    corrects_state = True
    python_steps = False
    rows = 0
    work = 0

    @abc.abstractmethod
    def tableau(self, run):
        """The Tableau of this run (``run``: pinclear.stepping.run.Run)."""

    def setup(self, run):
        """The method's own per-run state (contract 7); nothing by default."""

    def start(self, run, t, x, hint, zero):
        from .chunk import start
        return start(run.system, run.tab, run.st, float(t), np.ascontiguousarray(x, float),
                     -1.0 if hint is None else float(hint), int(zero))

    def stats(self, run) -> dict:
        return {}

    def check_options(self, *, h=None, max_step=None, first_step=None):
        if self.adaptive and h is not None:
            raise InputError(f"integrator {self.name!r} is adaptive (rtol/atol): the fixed step h applies only "
                             "to 'RK4'", key="h")
        if not self.adaptive:
            if h is None:
                raise InputError(f"integrator {self.name!r} is fixed-step: give h (seconds)", key="h")
            if max_step is not None and np.isfinite(max_step):
                raise InputError(f"integrator {self.name!r} is fixed-step: max_step does not apply (give h)",
                                 key="max_step")
            if first_step is not None:
                raise InputError(f"integrator {self.name!r} is fixed-step: first_step does not apply (give h)",
                                 key="first_step")
