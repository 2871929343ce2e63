"""Why a run did not succeed, as data: ``Failure(kind, t, detail)`` with ``kind`` a
:class:`FailureKind` (the one list of kinds: the atlas, the sweeps and a saved run's summary read
it), the time and the message. ``FailureKind`` members are strings too ("rank loss" ==
FailureKind.RANK_LOSS), as saved files hold them."""
from __future__ import annotations

from enum import Enum
from typing import NamedTuple


class FailureKind(str, Enum):
    """The kinds of a run's failure: what a program reading results tells apart without parsing
    the message."""
    STEP_SIZE = "step-size collapse"
    RANK_LOSS = "rank loss"
    SINGULAR = "singular matrix"
    NONFINITE = "non-finite"
    BUDGET = "budget"
    EXCEPTION = "exception"
    INTERRUPTED = "interrupted"
    CONSTRAINT = "constraint violated"
    FIXED_STEP = "fixed step too large"
    #: a formulation left part of a row's constraint force unapplied beyond the run's tolerance
    #: (the proximal method with too few iterations): the loops flex while their residual stays small
    UNAPPLIED = "constraint force unapplied"

    def __str__(self):
        return self.value


class Failure(NamedTuple):
    """A run's failure: its kind, the time it happened (s; None when not known) and the message."""
    kind: FailureKind
    t: float | None
    detail: str
