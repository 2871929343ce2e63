"""The tolerances of a run when none are given: the one place their defaults and the atol rule are
written (pinclear.dynamics.simulation checks a run's tolerances; pinclear.dynamics.validate reads
a checkpoint's back)."""
from __future__ import annotations

#: the relative tolerance when none is given (bifurcation() derives its period tolerance from it)
RTOL_DEFAULT = 1e-8
#: rtol outside this range is either below double precision or no error control at all
RTOL_RANGE = (1e-14, 1e-1)
#: the absolute tolerance when none is given, as a fraction of rtol (:func:`default_atol`)
ATOL_PER_RTOL = 1e-2


def default_atol(rtol, atol=None):
    """The absolute tolerance of a run: ``atol`` when given, else ATOL_PER_RTOL x rtol (None
    without an rtol: a fixed-step run)."""
    if atol is not None or rtol is None:
        return atol
    return rtol * ATOL_PER_RTOL
