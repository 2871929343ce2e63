"""A run's ODE system as data: the stages of one evaluation and the buffers they share.

The state is x = [c, v, z]: c the configuration coordinates (q itself for a Euclidean tree, a chart
around an anchor otherwise), v the joint velocities, z the force elements' internal states and
the drive work meter. An evaluation copies x into the run's state buffer ``System.x`` (the
workspace's ``ws.x``, whose views ``ws.q``, ``ws.v``, ``ws.z`` every kernel reads), runs the
stages in order — Pinocchio's passes, placements, force elements, drive laws, the formulation's
solve, the work meter — and assembles dx = [dc/dt, a, dz/dt] from the buffers they wrote.
The same three functions serve every integrator, compiled or Python-driven (Python calls them
through numba's dispatcher).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pinclear.core.call import NONFINITE, run_stages
from pinclear.core.jit import njit


class System(NamedTuple):
    """The compiled view of a run's evaluation (built by pinclear.dynamics.stepping.build)."""
    #: (k, 2) int64 rows (fn, ctx) of the right-hand side's stages, in order
    stages: np.ndarray
    #: (k, 2) stages writing every event channel's value into ``g``
    events: np.ndarray
    #: (k, 2) stages moving the state buffer onto the constraint manifold (none: no projection)
    project: np.ndarray
    #: (n,) the state buffer the stages read (and the projection writes)
    x: np.ndarray
    #: (nv,) accelerations written by the solve
    a: np.ndarray
    #: (nz,) internal-state rates written by the elements and the work meter
    zdot: np.ndarray
    #: (ng,) event values written by the event stages
    g: np.ndarray
    #: (nc,) dc/dt written by the chart stage of a non-Euclidean tree; empty: dc/dt = v
    crate: np.ndarray
    #: int64 counters: [evaluations]
    count: np.ndarray
    #: every row's multiplier as the solve wrote it (ws.lam) and the drive rows among them: the
    #: drive-force peaks are read there (pinclear.dynamics.stepping.peaks)
    lam: np.ndarray
    drows: np.ndarray
    #: (k, 2) stages writing each clearance's total normal force at the state buffer into ``pval``
    #: (the contact-force peaks, located between steps on the dense output)
    peaks: np.ndarray
    pval: np.ndarray


@njit(cache=True)
def evaluate(sys, t, x, dx):
    """dx = f(t, x). Returns the evaluation's code (pinclear.core.call): the smallest of its
    stages' codes, NONFINITE when dx is not finite."""
    n, nv, nz = x.shape[0], sys.a.shape[0], sys.zdot.shape[0]
    nc = n - nv - nz
    for i in range(n):
        sys.x[i] = x[i]
    sys.count[0] += 1
    code = run_stages(sys.stages, t)
    if sys.crate.shape[0]:
        for i in range(nc):
            dx[i] = sys.crate[i]
    else:
        for i in range(nc):
            dx[i] = x[nc + i]
    s = 0.0
    for i in range(nv):
        dx[nc + i] = sys.a[i]
        s += sys.a[i]
    for i in range(nz):
        dx[nc + nv + i] = sys.zdot[i]
        s += sys.zdot[i]
    if code >= 0.0 and not np.isfinite(s):
        return NONFINITE
    return code


@njit(cache=True)
def stage_values(sys, stages, t, x, buf, out):
    """out = what ``stages`` write into ``buf`` at (t, x) (the state buffer filled first)."""
    for i in range(x.shape[0]):
        sys.x[i] = x[i]
    run_stages(stages, t)
    for i in range(out.shape[0]):
        out[i] = buf[i]


@njit(cache=True)
def event_values(sys, t, x, g):
    """g = every event channel's value at (t, x) (functions of position, ForceElement contract)."""
    stage_values(sys, sys.events, t, x, sys.g, g)


@njit(cache=True)
def project(sys, t, x):
    """x moved onto the constraint manifold in place (no-op without projection stages); the code."""
    if sys.project.shape[0] == 0:
        return np.inf
    for i in range(x.shape[0]):
        sys.x[i] = x[i]
    code = run_stages(sys.project, t)
    for i in range(x.shape[0]):
        x[i] = sys.x[i]
    return code


@njit(cache=True)
def peak_values(sys, t, x, out):
    """out = every clearance's total normal force at (t, x) (the peak stages; no evaluation)."""
    stage_values(sys, sys.peaks, t, x, sys.pval, out)


def ode_system(fn, n, nc=0):
    """A System for a plain ODE, no mechanism: ``fn`` the address of a C stage
    (pinclear.core.call.CALLBACK) whose ctx is the address of one buffer holding x (n
    numbers) followed by the rates it writes there; the first nc states have dc/dt = v (the next
    nc states), so it writes only the n - nc others. Returns (System, buffer)."""
    buf = np.zeros(2 * n - nc)
    empty = np.zeros((0, 2), dtype=np.int64)
    return System(np.array([[fn, buf.ctypes.data]], dtype=np.int64), empty, empty, buf[:n], buf[n:], np.zeros(0),
                  np.zeros(0), np.zeros(0), np.zeros(1, dtype=np.int64), np.zeros(0), np.zeros(0, dtype=np.int64),
                  empty, np.zeros(0)), buf
