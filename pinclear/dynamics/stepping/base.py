"""One small base class for the integrators (after SciPy's integrate/_ivp: one method per file,
pinclear.dynamics.stepping.rk, .rosenbrock, .external), registered by name in pinclear.core.registry.INTEGRATORS.

This module imports no step logic: the Run (pinclear.dynamics.stepping.run) calls the compiled start and
the chunks, and a method only answers for its own coefficients and state, so rk.py and
rosenbrock.py can define their kernels and their Method in one file without an import circle.
"""
from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from pinclear.core.errors import InputError


class MethodState(NamedTuple):
    """What a method owns in one run, made by :meth:`Method.setup` and held by the Run (and its
    RunResult): ``tab``, the coefficients the compiled steps read (pinclear.dynamics.stepping.state.
    Tableau); ``W``, its work array (the run's Steps.W; the Rosenbrock method's Jacobian, LU and
    counters); ``driver``, the Python object a method stepped in Python calls back (SciPy's
    solver and the compiled callbacks, kept alive for the run), None for a compiled method."""
    tab: Any
    W: np.ndarray
    driver: Any = None


class Method:
    """How a run integrates. The contract (the run relies on nothing else):

    1. ``name`` is the user-facing name; ``adaptive`` says whether it takes rtol/atol (error
       control) or a fixed step ``h``; giving the other kind of option is an InputError
       (:meth:`check_options`).
    2. :meth:`tableau` returns its coefficients (pinclear.dynamics.stepping.state.Tableau) for the
       compiled step logic, which takes its steps (pinclear.dynamics.stepping.chunk.step dispatches on
       the tableau's kind: explicit Runge-Kutta, embedded or fixed-step, with any Butcher
       tableau; Rosenbrock-W with any coefficients; or EXTERNAL, a step and a dense output
       taken in Python through callbacks, as pinclear.dynamics.stepping.external wraps any SciPy
       OdeSolver) and shares everything after a step with every other method; ``rows`` and
       ``work`` are the rows of the stage array K and of the work array W it needs.
    3. :meth:`setup` makes the method's own state for one run (a MethodState: coefficients, work
       array, driver) from the run's sizes; it writes nothing into the run.
    4. :meth:`restart` is called after the run's compiled start at (t, x) (the first start, after
       an event, at a new chart anchor): what the method forgets or rebuilds there.
    5. ``corrects_state`` says whether a state changed after a step (projection) can be put into
       its running state; if not, projection methods cannot use it.
    6. :meth:`stats` adds the method's own counters to a run's stats (Jacobians, LU).
    7. ``python_steps`` says whether its steps are taken in Python (SciPy's solvers), which a
       run's ``stats["loop"]`` reports.
    8. :meth:`saved_state` / :meth:`restore_state`: what it carries from step to step beyond the
       state and the step size, for checkpoints (a dict of arrays; {} when nothing), and how it
       is put back at a resume point.
    """

    name = ""
    adaptive = True
    corrects_state = True
    python_steps = False
    rows = 0
    work = 0

    def tableau(self, run):
        """The Tableau of this run (``run``: pinclear.dynamics.stepping.run.Run), for the default setup; a
        method that overrides setup need not give one."""
        raise NotImplementedError(f"integrator {self.name!r} gives no tableau")

    def setup(self, run) -> MethodState:
        """The method's own per-run state (contract 3): its tableau and a zeroed work array."""
        return MethodState(self.tableau(run), np.zeros((self.work, run.st.V.shape[1])))

    def restart(self, own: MethodState, st, t, x, hint):
        """After the compiled start at (t, x) (contract 4); nothing by default."""

    def stats(self, own: MethodState, st) -> dict:
        return {}

    def saved_state(self, own: MethodState) -> dict:
        """The arrays a checkpoint keeps (contract 8); none by default."""
        return {}

    def check_saved_state(self, own: MethodState, state: dict, path: str) -> dict:
        """``state`` (a checkpoint's, same shapes as saved_state's, checked by the caller) as
        this method reads it; InputError naming ``path`` for values it never writes."""
        return state

    def restore_state(self, own: MethodState, state: dict):
        """Put a checked saved state back after the restart at the resume point."""

    def check_options(self, *, h=None, max_step=None, first_step=None):
        if self.adaptive and h is not None:
            raise InputError(f"integrator {self.name!r} is adaptive (rtol/atol): the fixed step h applies only "
                             "to fixed-step integrators", key="h")
        if not self.adaptive:
            if h is None:
                raise InputError(f"integrator {self.name!r} is fixed-step: give h (seconds)", key="h")
            if max_step is not None and np.isfinite(max_step):
                raise InputError(f"integrator {self.name!r} is fixed-step: max_step does not apply (give h)",
                                 key="max_step")
            if first_step is not None:
                raise InputError(f"integrator {self.name!r} is fixed-step: first_step does not apply (give h)",
                                 key="first_step")
