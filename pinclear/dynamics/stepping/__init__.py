"""The stepping engine: one step logic, compiled once, for every formulation, integrator and
force element (docs/design.md, "The stepping engine").

A run's evaluation is a list of stages (``stage``: kernels bound to the workspace's buffers,
called through C addresses: ``call``), assembled from the plug-ins (``build``) into a ``System``
(``system``: evaluate, event values, projection). The integrators (``base.Method``: ``rk`` for
RK45, DOP853, RK4; ``rosenbrock``; ``external`` for SciPy's) give their coefficients to the
shared step logic (``chunk``: chunks of accepted steps, and after each the singular-passage
search, events, samples, projection and the stall test, with ``checks`` and ``roots``);
``run.Run`` drives the chunks from Python. The integrators are registered by name in
pinclear.core.registry.INTEGRATORS (one module and one line each).
"""
from pinclear.core.errors import InputError
from pinclear.core.registry import INTEGRATORS


def get(name):
    """The integrator registered as ``name`` (pinclear.core.registry.INTEGRATORS)."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise InputError(f"unknown integrator {name!r}", key="integrator", choices=INTEGRATORS) from None
