"""Exact acceleration-level constraints (no Baumgarte) plus projection of q and v back onto the
constraint manifold after every accepted step (and on every output sample):

* positions: Gauss-Newton on Phi(q, t) = 0 over the kept rows with minimum-norm steps
  dq = -J^+ Phi (J^T's pivoted Householder QR), until |Phi|_inf < ``tol``, ``max_iter`` steps, or
  a step that does not reduce it (:func:`stalled`);
* velocities: the mass-metric projection onto J v + Phi_t = 0,
      v <- v - M^-1 J^T S^+ (J v + Phi_t),   S = J M^-1 J^T,
  evaluated with M = L^T L (tree-sparse) and B = J L^-1 as
      v <- L^-1 ((I - Q Q^T) L v - B^+ Phi_t),   Q an orthonormal basis of range(B^T),
  so no normal equations are formed (B^T's pivoted QR gives Q and B^+).

Both run in one compiled kernel (:func:`project_state`), which calls Pinocchio's position passes
itself at every iterate (pinclear.model.native's passes, placements through a bound stage), so a run's
projection never leaves compiled code; :meth:`Projection.project` calls the same stage from
Python. The proximal formulation projects with the same kernel, its steps filtered by its
proximal iterations instead of the pseudo-inverse.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from pinclear.core.call import ERROR, NONFINITE, OK, RANK, call_passes, call_stage
from pinclear.core.dense import (
    WIDE,
    chol_pivoted,
    chol_solve_pivoted,
    gram_rows,
    min_norm_x,
    project_out,
    qr_pivoted,
    support_runs_add,
)
from pinclear.core.errors import InputError
from pinclear.core.jit import njit
from pinclear.core.regularised import proximal_filter, relative_rho
from pinclear.core.stage import T, bind, python_stage
from pinclear.core.tree_solve import ltl_factor, ltl_solve, scaled_rows, schur_complement
from pinclear.dynamics.formulations.lagrange import Lagrange
from pinclear.model import native
from pinclear.model.frames import joint_placements_jacobians
from pinclear.model.rows import constraint_rows_all

#: relative pivot below which a direction of J^T (or of B^T = (J L^-1)^T) is dropped from the
#: minimum-norm steps: singular values below 1e-6 of the largest, as a least-squares solve of the
#: normal equations J J^T x = Phi with rcond 1e-12 drops them (their squares), without forming them
RCOND = 1e-6


#: the smallest pivot of J J^T, relative to its first, at which a minimum-norm step still takes
#: the Cholesky factor of J J^T (:func:`min_norm_step_gram`): its relative error is then at
#: most ~eps / GRAM_GATE = 2e-8 of a step that is itself O(distance to the manifold)
GRAM_GATE = 1e-8


#: a Gauss-Newton step that reduces the residual by less than this factor ends the iterations
#: (:func:`stalled`)
STALL = 0.99


@njit(cache=True)
def stalled(res, prev):
    """True when a Gauss-Newton iterate's residual res is below the previous one's, prev, by less
    than 1%: the iterations have reached Phi's rounding floor, or, near a flat configuration,
    the proximal steps (which filter the vanishing direction) have all but stopped converging.
    On A02 N = 10 near flat both leave residuals of 1e-11 to 2e-8 that 30 more steps reduce by
    less than 3x; every such projection used to run all ``max_iter`` steps: 59 of the 636
    projections of a 0.5 s proximal + ROS34PW2 run, a third of its CPU. A step that *raises*
    the residual does not end them: a minimum-norm step can jump through a pivot just above
    ``rcond`` (on the Bricard linkage's redundant closure, with the manifold's rcond then 1e-13,
    from 1e-12 to 3e-8) and the next steps come back below ``tol``. Newton's linear rate at a
    double root (1/2) is far from the bound."""
    return STALL * prev <= res <= prev


class Positions(NamedTuple):
    """What a kernel needs to move q and run Pinocchio's position passes from compiled code (one
    workspace): the passes (pinclear.model.native.Passes), the stage computing the placements of the
    frames the rows read at ``q``, the stage integrating ``q`` along ``dq`` (0: plain addition,
    a Euclidean tree), the configuration buffer (the state buffer's q), the step, v = 0 and the
    count of Gauss-Newton steps the last projection took (ws.gn_steps)."""
    passes: int
    model: int
    data: int
    place_fn: int
    place_ctx: int
    integ_fn: int
    integ_ctx: int
    q: np.ndarray
    dq: np.ndarray
    zero_v: np.ndarray
    jacobians: int       # 1: the placements stage also writes the joint Jacobian (a 1-dof tree)
    steps: np.ndarray    # (1,) int64


def position_passes(form):
    """(Positions of ``form``'s workspace, what must stay alive while they are bound). Trees the
    compiled joint chain covers get compiled placements; others copy Pinocchio's data.oMi, and
    non-Euclidean trees integrate with pin.integrate, both through Python stages (those trees run
    the Python loop: pinclear.dynamics.stepping.build)."""
    mech, ws = form.mech, form.ws
    passes, keep = native.passes_for(mech, ws)
    if ws.fk.chain is not None:
        # placements and the WORLD joint Jacobian in one compiled call: Pinocchio's position pass
        # (computeJointJacobians) is not needed at the iterates (about 1.2 us of each of 3-UPRU+UP's)
        place = bind(joint_placements_jacobians, ws.fk.placement_args(ws.q) + (ws.J6,),
                     name="placements and joint Jacobians")
    else:
        def copy_placements(t):
            ws.fk.load_placements(ws.data, ws.q)
            return np.inf
        place = python_stage(copy_placements, form.errors, name="placements (copied from Pinocchio's data)")
    dq = np.zeros(mech.nv)
    integ_fn = integ_ctx = 0
    integ = None
    if not mech.euclidean:
        def integrate(t):
            ws.q[:] = pin.integrate(mech.model, ws.q, dq)
            return np.inf
        integ = python_stage(integrate, form.errors, name="pin.integrate")
        integ_fn, integ_ctx = integ.fn, integ.ctx
    P = Positions(passes.fn, passes.model, passes.data, place.fn, place.ctx, integ_fn, integ_ctx, ws.q, dq, ws.zero_v,
                  int(ws.fk.chain is not None), ws.gn_steps)
    return P, (keep, place, integ)


@njit(cache=True, inline="always")
def at_positions(P, flags, t):
    """The placements of the rows' frames and the joint Jacobian at P.q: Pinocchio's position
    passes (with native.MASS in ``flags``: crba too) unless the placement stage computes both
    (a 1-dof tree, pinclear.model.frames.joint_placements_jacobians), then that stage; the
    placement stage's code (ERROR: a Python stage raised). Pinocchio's data.oMi is then not
    at P.q: what follows at the iterates reads only the placements, J and crba's own pass."""
    if P.jacobians == 0 or flags != 0:
        call_passes(P.passes, P.model, P.data, P.q.ctypes.data, P.zero_v.ctypes.data, native.POSITIONS | flags)
    return call_stage(P.place_fn, P.place_ctx, t)


@njit(cache=True, inline="always")
def move(P, t):
    """q <- integrate(q, dq): plain addition on a Euclidean tree; the code."""
    if P.integ_fn == 0:
        for i in range(P.q.shape[0]):
            P.q[i] += P.dq[i]
        return OK
    return call_stage(P.integ_fn, P.integ_ctx, t)


@njit(cache=True, inline="always")
def mass_only(P):
    """crba at P.q, whose positions are done."""
    call_passes(P.passes, P.model, P.data, P.q.ctypes.data, P.zero_v.ctypes.data, native.MASS_ONLY)


@njit(cache=True)
def ltl_mul(Lm, parent, v, x):
    """x = L v for M = L^T L, L upper-triangular in the tree pattern: (L v)_k sums over k and its
    ancestors (pinclear.core.tree_solve.ltl_factor)."""
    for c in range(v.shape[0]):
        s = Lm[c, c] * v[c]
        i = parent[c]
        while i >= 0:
            s += Lm[c, i] * v[i]
            i = parent[i]
        x[c] = s


class Projector(NamedTuple):
    """The buffers of :func:`project_state`: the velocity (the state buffer's v), the drive
    values, Pinocchio's M, the tree's parents, the rows projected onto and work arrays sized by
    them (k rows)."""
    v: np.ndarray
    fdrv: np.ndarray
    M: np.ndarray
    parent: np.ndarray
    rows: np.ndarray     # (k,)
    Qr: np.ndarray       # (k, nv) pivoted QR of J^T, then of B^T (row-wise: pinclear.core.dense.qr_pivoted)
    piv: np.ndarray      # (k,) int64
    hb: np.ndarray       # (k,)
    Lm: np.ndarray       # (nv, nv) M = L^T L
    Y: np.ndarray        # (k, nv) B = J L^-1, row-wise
    S: np.ndarray        # (k, k) J J^T, then B B^T (the proximal filter's matrix)
    F: np.ndarray        # (k, k) its proximal factor
    d: np.ndarray        # (k,)
    r: np.ndarray        # (k,)
    w: np.ndarray        # (k,)
    x: np.ndarray        # (nv,)


def projector(form, rows):
    """The Projector of ``form``'s workspace over ``rows`` (bound as it is: keep the array)."""
    ws, nv, k = form.ws, form.mech.nv, len(rows)
    return Projector(ws.v, ws.drive_data.f, ws.data.M, ws.parent, rows, np.zeros((k, nv)), np.zeros(k, dtype=np.int64),
                     np.zeros(k), np.zeros((nv, nv)), np.zeros((k, nv)), np.zeros((k, k)), np.zeros((k, k)),
                     np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(nv))


@njit(cache=True)
def row_residual(phi, rows):
    """max |Phi| over ``rows``: the Gauss-Newton iterations' residual (projections, manifold)."""
    res = 0.0
    for i in range(rows.shape[0]):
        res = max(res, abs(phi[rows[i]]))
    return res


@njit(cache=True, inline="always")
def _filtered(W, k_prox, rho_rel):
    """W.w = the proximal filter of W.S applied to W.r (k_prox iterations, rho relative to the
    mean diagonal of S)."""
    proximal_filter(W.S, W.r, relative_rho(W.S, rho_rel), k_prox, W.F, W.d, W.w)


@njit(cache=True)
def min_norm_step(Jc, phi, rows, Qr, piv, hb, r, rcond, dq):
    """dq = -J^+ Phi over ``rows``, minimum norm (J^T's pivoted QR in Qr, pivots below rcond
    dropped; r: work of len(rows)): one Gauss-Newton step of the projections and the manifold
    formulation."""
    m, nv = rows.shape[0], dq.shape[0]
    for i in range(m):
        r[i] = phi[rows[i]]
        for c in range(nv):
            Qr[i, c] = Jc[rows[i], c]
    kk = qr_pivoted(Qr, piv, hb, rcond)
    min_norm_x(Qr, piv, hb, kk, r, dq)
    for c in range(nv):
        dq[c] = -dq[c]


@njit(cache=True)
def min_norm_step_gram(Jc, phi, rows, cols, ncols, G, Lg, pg, dg, yg, Qr, piv, hb, r, rcond, dq):
    """min_norm_step by the Cholesky factor of G = J J^T (dq = -J^T G^-1 Phi) while every
    pivot of G stays above GRAM_GATE times the first (pinclear.core.dense.chol_pivoted), the
    pivoted QR below it (near rank loss, where it is the minimum-norm step the QR's truncation
    defines). The two differ by rounding: at most ~eps / GRAM_GATE relative to |dq|, which is
    O(d) at a point d off the manifold; the Gram matrix and its factor cost less than the QR
    (benchmarks/kernel_choices.md)."""
    m = rows.shape[0]
    gram_rows(Jc, rows, cols, ncols, G)
    if chol_pivoted(G, pg, Lg, dg, GRAM_GATE) > 0.0:
        for i in range(m):
            r[i] = phi[rows[i]]
        chol_solve_pivoted(Lg, pg, r, yg, r)
        minus_jt_times(Jc, rows, cols, ncols, r, dq)
        return
    min_norm_step(Jc, phi, rows, Qr, piv, hb, r, rcond, dq)


@njit(cache=True, inline="always")
def minus_jt_times(Jc, rows, cols, ncols, w, dq):
    """dq = -J[rows]^T w (each entry summed over the rows in order from zero), row by row over
    each row's support (the products skipped are exact zeros: the same bits as the dense sum);
    from WIDE rows along the supports' runs of columns (support_runs_add, the same bits)."""
    dq[:] = 0.0
    if rows.shape[0] >= WIDE:
        for i in range(rows.shape[0]):
            ri = rows[i]
            support_runs_add(dq, Jc[ri], cols[ri], ncols[ri], -w[i])
        return
    for i in range(rows.shape[0]):
        ri, wi = rows[i], w[i]
        for kk in range(ncols[ri]):
            k = cols[ri, kk]
            dq[k] -= Jc[ri, k] * wi


@njit(cache=True, inline="always")
def gauss_newton_step(R, W, rcond, k_prox, rho_rel, dq):
    """dq = -J^+ Phi over W.rows (k_prox = 0: min_norm_step), or dq = -J^T f(J J^T) Phi with the
    proximal filter f of k_prox iterations."""
    Jc, phi, rows, r = R.Jc, R.phi, W.rows, W.r
    if k_prox == 0:
        min_norm_step(Jc, phi, rows, W.Qr, W.piv, W.hb, r, rcond, dq)
        return
    for i in range(rows.shape[0]):
        r[i] = phi[rows[i]]
    gram_rows(Jc, rows, R.cols, R.ncols, W.S)        # S = J J^T
    _filtered(W, k_prox, rho_rel)
    minus_jt_times(Jc, rows, R.cols, R.ncols, W.w, dq)


@njit(cache=True, inline="always")
def project_state(P, R, W, t, tol, max_iter, rcond, k_prox, rho_rel):
    """The state buffer's (q, v) moved onto the constraint manifold over W.rows (module doc):
    Gauss-Newton steps while |Phi|_inf >= tol (at most max_iter, and while each reduces it:
    :func:`stalled`), then the mass-metric velocity projection at the last iterate.
    ``k_prox`` = 0: minimum-norm steps (pseudo-inverses by pivoted QR, pivots below ``rcond``
    dropped); > 0: the proximal filter of ``k_prox`` iterations with rho = ``rho_rel`` times the
    mean diagonal (pinclear.dynamics.formulations.proximal).
    Returns OK, RANK (M not positive definite), NONFINITE, or ERROR (a Python stage raised)."""
    q, v, rows, zero = P.q, W.v, W.rows, P.zero_v
    m, nv = rows.shape[0], v.shape[0]
    settled = False
    prev = np.inf
    P.steps[0] = 0
    for _ in range(max_iter):
        if at_positions(P, 0, t) == ERROR:
            return ERROR
        constraint_rows_all(R, 0.0, 0.0, q, zero, W.fdrv)
        res = row_residual(R.phi, rows)
        if res < tol or stalled(res, prev):
            settled = True
            break
        prev = res
        gauss_newton_step(R, W, rcond, k_prox, rho_rel, P.dq)
        if move(P, t) == ERROR:
            return ERROR
        P.steps[0] += 1
    if not settled:                  # the last step's positions and rows, for the velocities
        if at_positions(P, 0, t) == ERROR:
            return ERROR
        constraint_rows_all(R, 0.0, 0.0, q, zero, W.fdrv)
    # R.dphi at v = 0 is Phi_t (the drive rows' -f'(t); zero for closures)
    mass_only(P)
    Lm, x, Y, dphi = W.Lm, W.x, W.Y, R.dphi
    if not ltl_factor(W.M, W.parent, Lm):
        return RANK
    ltl_mul(Lm, W.parent, v, x)                  # x = L v
    if k_prox == 0:
        # x <- (I - Q Q^T) x - B^+ Phi_t, Q spanning range(B^T)
        scaled_rows(Lm, W.parent, R.Jc, rows, Y)
        for i in range(m):
            for c in range(nv):
                W.Qr[i, c] = Y[i, c]
        kk = qr_pivoted(W.Qr, W.piv, W.hb, rcond)
        project_out(W.Qr, W.hb, kk, x)
        for i in range(m):
            W.r[i] = dphi[rows[i]]
        xs = P.dq
        min_norm_x(W.Qr, W.piv, W.hb, kk, W.r, xs)
        for c in range(nv):
            x[c] -= xs[c]
    else:
        # x <- x - B^T f(B B^T) (B x + Phi_t)
        schur_complement(Lm, W.parent, R.Jc, rows, R.cols, R.ncols, Y, W.S)
        for i in range(m):
            s = dphi[rows[i]]
            for c in range(nv):
                s += Y[i, c] * x[c]
            W.r[i] = s
        _filtered(W, k_prox, rho_rel)
        for i in range(m):
            wi = W.w[i]
            for c in range(nv):
                x[c] -= Y[i, c] * wi
    ltl_solve(Lm, W.parent, x)
    s = 0.0
    for c in range(nv):
        v[c] = x[c]
        s += x[c]
    for i in range(q.shape[0]):
        s += q[i]
    return OK if np.isfinite(s) else NONFINITE


def run_projection(form, stage, t, q, v):
    """(q, v) moved by a projection stage called from Python: the same kernel on the same
    buffers as in a compiled run (the drive values at t first, as the run's drive stages). Raises
    what a Python stage inside raised, or LinAlgError when M is not positive definite."""
    ws = form.ws
    if q is not ws.q:
        ws.q[:] = q
    if v is not ws.v:
        ws.v[:] = v
    form.drive_values(t)
    code = stage(t)
    if code == ERROR:
        raise form.errors.pop()
    if code == RANK:
        raise np.linalg.LinAlgError(f"{form.mech.name}: the mass matrix is not positive definite at t = {t:.9g} s "
                                    "(check the URDF inertias)")
    return ws.q.copy(), ws.v.copy()


class Projection(Lagrange):
    name = "projection"
    options = {"tol": 1e-12, "max_iter": 10, "drop_redundant": True}

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        self.opts["max_iter"] = iterations(self.name, self.opts["max_iter"])
        self._projection = None

    @property
    def supports_projection(self):
        return self.mech.m > 0           # no rows: nothing to project onto

    def baumgarte(self):
        return (0.0, 0.0)

    def use_rows(self, independent):
        super().use_rows(independent)
        self._projection = None          # its buffers are sized by the kept rows

    def projection_stage(self):
        """The bound projection kernel (minimum-norm steps over the kept rows)."""
        if self._projection is None:
            P, keep = position_passes(self)
            W = projector(self, self.rows)
            o = self.opts
            self._projection = (bind(project_state, (P, self.row_buffers, W, T, float(o["tol"]), o["max_iter"], RCOND,
                                                     0, 0.0), code=True, name=f"{self.name} projection"), keep)
        return self._projection[0]

    def compiled(self):
        comp = super().compiled()
        if not self.supports_projection:
            return comp
        return comp._replace(project=self.drive_stages()
                             + (self.projection_stage(),))

    def project(self, t, q, v):
        if not self.supports_projection:
            return q, v
        return run_projection(self, self.projection_stage(), t, q, v)


def iterations(method, value, key="max_iter"):
    """An option counting iterations as an int >= 1 (10.0 is accepted: range() and the bound
    kernels need the int), or an InputError naming the key."""
    if (isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating))
            or not float(value).is_integer() or value < 1):
        raise InputError(f"method {method!r}: option {key!r} must be an integer >= 1, got {value!r}", key=key)
    return int(value)
