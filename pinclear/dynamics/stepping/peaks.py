"""Peaks from the integration (docs/outputs.md, "Peaks"): the largest drive forces, accelerations
and contact forces of a run, taken over its accepted steps rather than over its output samples,
so they do not depend on the output grid.

* Drive forces (each drive row's |multiplier|) and accelerations (each dof's |a|): over the
  evaluations the steps already made at their accepted states (the first-same-as-last
  evaluation of RK45, DOP853, RK4 and ROS34PW2, the evaluation after a projection, the one at a
  (re)start); no evaluation is added. Resolution: the accepted steps, which the error control
  makes short where these forces change fast (impacts).
* Contact forces (each clearance's total normal force, a function of the state alone): at each
  accepted state, and between two when the force rises at the step's start and falls at its
  end (one-sided differences of the force along the dense output), located by Brent's
  minimiser on the dense output (pinclear.dynamics.stepping.roots), as the step logic locates events.
  Each value costs the position-level placements, joint Jacobian and the joint's force kernel
  (the peak stages, ``System.peaks``), not an evaluation.

SciPy's Radau, BDF and LSODA take their steps in Python and need not evaluate at the accepted
state: their steps whose last evaluation is elsewhere add no drive-force or acceleration peak.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.jit import njit
from pinclear.dynamics.stepping.state import PK_MAX, PK_NOW, PK_T


@njit(cache=True)
def stage_forces(sys, pk):
    """pk[PK_NOW] = |drive multipliers| and |accelerations| of the last evaluation."""
    nd = sys.drows.shape[0]
    for k in range(nd):
        pk[PK_NOW, k] = abs(sys.lam[sys.drows[k]])
    for i in range(sys.a.shape[0]):
        pk[PK_NOW, nd + i] = abs(sys.a[i])


@njit(cache=True)
def fold(pk, lo, hi, t):
    """The peaks of columns lo..hi-1 updated with their PK_NOW values at time t (NaN never wins)."""
    for k in range(lo, hi):
        val = pk[PK_NOW, k]
        if val > pk[PK_MAX, k]:
            pk[PK_MAX, k] = val
            pk[PK_T, k] = t


@njit(cache=True)
def forces_at(sys, pk, t):
    """stage_forces then fold: the peaks of the evaluation just made at the state of time t."""
    stage_forces(sys, pk)
    fold(pk, 0, sys.drows.shape[0] + sys.a.shape[0], t)


def window_peak(t, y, t_from=None, t_to=None):
    """(largest |y|, its time) over the samples with t_from <= t <= t_to (either bound None:
    open); (nan, nan) when no finite sample lies in the window. The one definition of a peak
    over a window of samples: a run's summary after a transient (Trajectory.summary(peaks_after=
    T)) and the reproductions' steady-regime peaks both use it. Over samples, it is a lower
    bound of the peak between them (the accepted steps' peaks above do not depend on the grid)."""
    t = np.asarray(t, float)
    y = np.abs(np.asarray(y, float))
    keep = np.isfinite(y)
    if t_from is not None:
        keep &= t >= t_from
    if t_to is not None:
        keep &= t <= t_to
    if not keep.any():
        return float("nan"), float("nan")
    i = int(np.argmax(np.where(keep, y, -np.inf)))
    return float(y[i]), float(t[i])
