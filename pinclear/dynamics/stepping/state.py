"""The data of the step logic: an integrator's coefficients (``Tableau``) and a run's stepping
state (``Steps``), both NamedTuples of arrays so the compiled step functions take them as two
structured arguments. Scalars live in ``Steps.r`` (floats) and ``Steps.i`` (ints) under the
names below."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: integrator kinds (Tableau.kind)
RK_EMBEDDED, RK_DOP853, RK_FIXED, ROSENBROCK, EXTERNAL = range(5)

#: Steps.r: current time, time before the last accepted step, next step size, the last step
#: (signed), end of the integration, largest step, rtol, the stall test's mean step, the time and
#: code of the last bad evaluation, the located event's time, the step size an aborted step
#: started from, the fixed step (RK4); then the pivot monitor (pinclear.dynamics.stepping.checks): the
#: smallest ratio since the last accepted step, the run's first ratio (nan before), the rank floor
#: and the reselect factor
(T, T_OLD, H_ABS, H_PREV, T_BOUND, MAX_STEP, RTOL, H_STALL, T_BAD, CODE_BAD, T_EVENT, H_START,
 H_FIXED, MON_MIN, MON_REF, MON_FLOOR, MON_RESELECT) = range(17)
NR = 17
#: Steps.i: accepted steps (since the counters were reset), accepted steps of the run (the
#: stall ring's count), next output sample, consecutive bad evaluations, whether the dense
#: output of the last step is ready, the located event's channel, whether row reselection is
#: off until the next accepted step, whether x holds a chart (non-Euclidean tree), rejected
#: step attempts, Jacobian evaluations (implicit methods)
(STEPS, N_ACC, OUT_I, BAD, DENSE, EVENT_K, NO_RESELECT, CHART, REJECTS, NJAC) = range(10)
NI = 10
#: rows of Steps.V: the state after the last accepted step and f there, the state before it and
#: f there, a stage state, the proposed state, the absolute tolerance (inf: out of the error
#: test), the state at an event (and dense-output work), the state of the last bad evaluation,
#: derivative work
(Y, F, Y_OLD, F_OLD, YS, Y_NEW, ATOL, XE, XB, DX) = range(10)
NV = 10
#: rows of Steps.G (event channels): direction, values after the last accepted step, values at
#: the step's end, work
(DIRS, G_PREV, G_NEW, G_WORK) = range(4)
#: rows of Steps.pk (peaks from the integration, pinclear.dynamics.stepping.peaks; columns: the drives,
#: the accelerations, the clearances): the largest value so far (-1 before any), its time, the
#: value at the last accepted state, its slope there (clearances: the change over a small
#: fraction of the step; nan: not known), work
(PK_MAX, PK_T, PK_NOW, PK_SLOPE, PK_W1, PK_W2, PK_W3) = range(7)
NPK = 7


class Tableau(NamedTuple):
    """An integrator's coefficients; fields a kind does not use are empty arrays."""
    kind: int
    #: error estimator order (the step-size exponent is -1 / (order + 1))
    order: int
    #: Runge-Kutta (or Rosenbrock) coefficients: stage matrix, weights, nodes
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    #: error estimator weights over the stages and the final derivative (RK45); E3, E5: DOP853's
    E: np.ndarray
    E3: np.ndarray
    E5: np.ndarray
    #: RK45's dense output polynomial (stages + 1, 4)
    P: np.ndarray
    #: DOP853's extra dense-output stages and interpolation coefficients
    AX: np.ndarray
    CX: np.ndarray
    DX: np.ndarray
    #: Rosenbrock: the stage coupling matrix Gamma and its diagonal gamma
    G: np.ndarray
    gamma: float
    #: external (SciPy) integrators: addresses of the step, dense and reset callbacks
    ext: np.ndarray


_EMPTY1 = np.zeros(0)
_EMPTY2 = np.zeros((0, 0))


def tableau(kind, order, **fields) -> Tableau:
    """A Tableau with the given fields (float64, contiguous) and empty arrays for the others."""
    out = {}
    for name in Tableau._fields[2:]:
        default = {"gamma": 0.0, "ext": np.zeros(3, dtype=np.int64)}.get(
            name, _EMPTY2 if name in ("A", "P", "AX", "DX", "G") else _EMPTY1)
        v = fields.pop(name, default)
        if name == "gamma":
            out[name] = float(v)
        elif name == "ext":
            out[name] = np.ascontiguousarray(v, dtype=np.int64)
        else:
            out[name] = np.ascontiguousarray(v, dtype=float)
    if fields:
        raise TypeError(f"unknown tableau fields {sorted(fields)}")
    return Tableau(int(kind), int(order), **out)


class Steps(NamedTuple):
    """A run's stepping state (one per run; the module doc names the rows and entries). Few arrays
    on purpose: a compiled call that is not inlined reference-counts every array of its
    arguments (~3 ns each), and the step functions pass this tuple around at every step."""
    V: np.ndarray          # (NV, n) state vectors
    K: np.ndarray          # (stages, n) stage derivatives (work of the method)
    W: np.ndarray          # (rows, n) method work (Rosenbrock: Jacobian and stage solves)
    D: np.ndarray          # (7, n) dense output coefficients of the last step
    r: np.ndarray          # (NR,) scalars and the pivot monitor
    i: np.ndarray          # (NI,) int64 counters and flags
    ring: np.ndarray       # (STALL_STEPS,) times of the last accepted steps (stall test, progress)
    G: np.ndarray          # (4, ng) event channels
    t_eval: np.ndarray     # (ns,) output times
    samples: np.ndarray    # (ns, n) output samples (written once each)
    search: np.ndarray     # Brent's state (roots.BRENT_STATE / ROOT_STATE, the larger)
    pk: np.ndarray         # (NPK, peaks) peaks from the integration (PK_MAX, ... above)


def new_steps(n, ng, t_eval, rows, work, search, ring, peaks=0):
    """Zeroed stepping state for a state of n components, ng event channels and ``peaks``
    watched quantities (no peak yet)."""
    pk = np.zeros((NPK, peaks))
    pk[PK_MAX] = -1.0
    pk[PK_T] = pk[PK_SLOPE] = np.nan
    return Steps(np.zeros((NV, n)), np.zeros((max(rows, 1), n)), np.zeros((work, n)), np.zeros((7, n)),
                 np.zeros(NR), np.zeros(NI, dtype=np.int64), np.zeros(ring), np.zeros((4, ng)),
                 np.ascontiguousarray(t_eval, float), np.zeros((len(t_eval), n)), np.zeros(search), pk)
