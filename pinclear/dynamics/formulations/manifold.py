"""Singular-passage formulation ("manifold"): the right-hand side is evaluated at the stage
state projected onto the constraint manifold (docs/singular_passages.md, "The manifold
formulation"). At every evaluation, from the stage state (q, v):

1. q1 = P(q): Gauss-Newton on Phi(q, t) = 0 with minimum-norm steps -J^+ Phi (Householder QR of
   J^T with column pivoting, pivots below ``rcond`` = 1e-8 of the largest dropped: a redundant
   row's pivot is O(distance) off the manifold, and 1e-13 kept it near the manifold, amplifying
   Phi's rounding into steps of ~1e-8 on the Bricard linkage), moved with pin.integrate. At
   the stages exactly one step, so q1 is the same smooth function of q whatever the stage's
   residual, equal to q on the manifold: the integrator sees a smooth right-hand side that is
   the exact one on the manifold, which keeps its order (the exact flow from a point on the
   manifold never leaves it), and the step leaves |Phi| ~ kappa d^2 at a stage d off (1e-16
   at d = 1e-8, against the d / eps the projection removes). Further steps (at most
   ``max_iter`` while |Phi| > ``tol`` and each step reduces it: not at Phi's rounding floor,
   pinclear.dynamics.formulations.projection.stalled) only in the exact projection after steps: at
   the stages they changed no result beyond rounding and cost 18 % of 4-UPS-UPR's
   evaluation (docs/singular_passages.md);
2. v1 = v - M^-1 J^T g(S) (J v + Phi_t) at q1, with S = J M^-1 J^T = B B^T (B = J L^-1,
   M = L^T L tree-sparse, pinclear.core.tree_solve.ltl_factor) and the filter g(s) = s / (s^2 + mu^4)
   on the closures' rows, scaled per unit group, the drives' rows exact (shifted_factor):
   S^-1 where s >> mu^2, nothing along the directions that vanish at a flat configuration;
3. a = L^-1 ((I - Q Q^T) y + B^T g(S) gamma), y = L^-T (tau - nle), gamma = -(dJ v1) v1 at
   (q1, v1), Q an orthonormal basis of range(B^T) (the same pivoted QR, truncated at pivots
   below ``rcond_v``). Where g(S) = S^-1 this is the exact a = L^-1 (y + B^+ (gamma - B y)).
4. near flat (smallest kept pivot below ``tangent`` times the largest), range(Q) is made
   orthogonal to x = L v1 first: exact arithmetic has x orthogonal to range(B^T) already, so
   this only replaces round-off (below).

Why (the study is in the doc): near a flat configuration one singular value sigma of B falls
like the crank angle eps. At a stage state d off the manifold the exact multipliers turn the
O(d) inconsistency of gamma - B y into an acceleration error ~ d / eps. At the projected state
that inconsistency is gone; what is left is round-off: Phi is known to ~1e-16, so q1 only to
1e-16 / sigma along the vanishing direction, the tangent there to 1e-16 / sigma^2, and the
exact velocity-squared term B^+ gamma to 1e-16 / sigma^3, which collapses the step size at
rtol 1e-10. Hence the split in 3: the reaction to the applied forces (Q Q^T y, a projector) is
exact at any eps and is what keeps the motion on its branch; the tangential acceleration
u^T M a = u^T (tau - nle) does not depend on the filter at all (u^T J^T = 0); only the
velocity-squared part and, at the stages, the velocity projection are filtered, which bounds
their round-off. That leaves the direction of the vanishing normal itself, known only to
1e-16 / sigma^2 at q1, so (I - Q Q^T) y leaked up to 1e-4 of gravity into the tangent near flat
and collapsed the step size on A02 N = 10 (docs/singular_passages.md). The velocity carries the
branch (it is O(1) away from the other branch's tangent, the position is not): step 4 takes the
tangential equation x^T L a = x^T y from it. After every accepted step the state is projected
with the exact velocity projection (``project``): v1 = L^-1 ((I - Q Q^T) L v - B^+ Phi_t), the
drives' rates through the pivoted QR's minimum-norm solve, unfiltered (filtered, they gave a
driven mechanism's samples velocities off by up to 100 %; docs/singular_passages.md).

The exact projection of the state the step logic evaluated last (the accepted state of an FSAL
step: RK45, DOP853, ROS34PW2) starts where that evaluation's stage projection ended: the same
first Gauss-Newton step from the same state, rows and factors at the same q1 (same_state: the
state and the drive values bitwise equal), so where |Phi(q1)| <= tol it only applies the exact
velocity projection to those factors, the very numbers it would compute again.

The QRs are needed only near rank loss: where every pivot of J J^T (resp. S) stays above a gate
the same quantities come from its Cholesky factor with diagonal pivoting (the QR's pivot order
and |R_jj| in exact arithmetic; projection.min_norm_step_gram, chol_gate), which costs a
fraction of the QR; below the gates, and always for the tangent of step 4, the QRs run
(docs/singular_passages.md, step 5).

Likewise the filter's complex factor of S + i mu^2 Lam (m^3 / 6 complex products) is needed only
near flat: where S's Cholesky factor is taken and the shift is far below S's eigenvalues,
g(S) r comes from a series of solves with that factor (series_filtered, the same g(S) r to
rounding), which declines where it would converge slowly and the factor runs
(benchmarks/bench_a02_scale.md: A02 N = 40, where the 80-row factor was the largest kernel)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pinclear.core.call import ERROR, OK, RANK
from pinclear.core.dense import (
    WIDE,
    chol_pivoted,
    chol_solve_pivoted,
    min_norm_solve,
    min_norm_x,
    project_out,
    qr_pivoted,
    support_runs_add,
)
from pinclear.core.errors import InputError
from pinclear.core.jit import njit
from pinclear.core.stage import T, bind
from pinclear.core.tree_solve import ltl_factor, ltl_solve, ltl_solve_t, schur_complement
from pinclear.dynamics.formulations.base import Compiled, Formulation, Solve
from pinclear.dynamics.formulations.filtered_solve import filtered_solve_ws, row_shifts, series_filtered, shifted_factor
from pinclear.dynamics.formulations.lagrange import lagrange_accel
from pinclear.dynamics.formulations.projection import (
    at_positions,
    iterations,
    ltl_mul,
    mass_only,
    min_norm_step_gram,
    move,
    position_passes,
    row_residual,
    stalled,
)
from pinclear.model import kinematics
from pinclear.model.rows import constraint_rows_positions, constraint_rows_velocities


class ManifoldWork(NamedTuple):
    """The buffers of the manifold kernels: the state buffer's q and v (rewritten with the
    projected state), the drive values, Pinocchio's M and nle, the applied forces, the outputs
    and the factors the projection leaves for the solve (m rows, every row)."""
    q: np.ndarray
    v: np.ndarray
    fdrv: np.ndarray
    M: np.ndarray
    parent: np.ndarray
    tau: np.ndarray
    nle: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    rows: np.ndarray     # (m,) 0..m-1
    Lm: np.ndarray       # (nv, nv) M = L^T L at q1
    Y: np.ndarray        # (m, nv) B = J L^-1
    S: np.ndarray        # (m, m) B B^T
    Fr: np.ndarray       # (m, m) complex L D L^T of S + i mu^2 I, real and imaginary parts
    Fi: np.ndarray
    Qr: np.ndarray       # (m, nv) pivoted QR of B^T (B row-wise: pinclear.core.dense.qr_pivoted)
    piv: np.ndarray
    hb: np.ndarray
    kk: np.ndarray       # (1,) its rank
    Qg: np.ndarray       # (m, nv) pivoted QR of J^T (the Gauss-Newton step)
    pg: np.ndarray
    hg: np.ndarray
    yr: np.ndarray       # (m,) filtered_solve_ws's complex work, real and imaginary parts
    yi: np.ndarray
    v1: np.ndarray       # (nv,) the projected velocity
    r: np.ndarray        # (m,) work
    w: np.ndarray        # (m,)
    xs: np.ndarray       # (nv,)
    xt: np.ndarray       # (nv,)
    wt: np.ndarray       # (nv,)
    grp: np.ndarray      # (mc,) each closure row's unit group (pinclear.model.closures: row_group)
    gcnt: np.ndarray     # (groups,) rows per group
    gsum: np.ndarray     # (groups,) work: the group's shift
    Gg: np.ndarray       # (m, m) J J^T of the Gauss-Newton step (projection.min_norm_step_gram)
    Lg: np.ndarray       # (m, m) its pivoted Cholesky factor
    dg: np.ndarray       # (m,) work
    yg: np.ndarray       # (m,) work
    Lc: np.ndarray       # (m, m) the pivoted Cholesky factor of S (velocity_projection)
    pc: np.ndarray       # (m,) its pivots
    chol: np.ndarray     # (1,) 1: S's factor is used at this q1 (far from rank loss), 0: B^T's QR
    last: np.ndarray     # (1,) 1: the buffers hold the last stage projection's (same_state); 2: an
    #                      exact projection has just taken them
    qin: np.ndarray      # (nq,) that stage's state and drive values
    vin: np.ndarray      # (nv,)
    fin: np.ndarray      # (3, drives)
    q1: np.ndarray       # (nq,) its projected configuration
    dsh: np.ndarray      # (m,) the filter's shift per row, mu^2 Lam_ii (row_shifts)
    filt: np.ndarray     # (1,) 1: g(S) by the series on S's Cholesky factor (series_filtered); 0: Fr, Fi


class Manifold(Formulation):
    name = "manifold"
    options = {"tol": 1e-12, "max_iter": 10, "rcond": 1e-8, "rcond_v": 1e-8, "mu": 1e-2, "tangent": 1e-3}
    # accelerations() leaves the pass of the projected state in ws.data, not the one of (q, v)
    fills_workspace = False

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        for key in ("tol", "rcond", "rcond_v", "mu"):
            if not (np.isfinite(self.opts[key]) and self.opts[key] > 0):
                raise InputError(f"method 'manifold': option {key!r} must be a positive number, "
                                 f"got {self.opts[key]!r}", key=key)
        if not (np.isfinite(self.opts["tangent"]) and 0.0 <= self.opts["tangent"] < 1.0):
            raise InputError(f"method 'manifold': option 'tangent' must be a number in [0, 1) (a relative pivot; "
                             f"0: off), got {self.opts['tangent']!r}", key="tangent")
        self.opts["max_iter"] = iterations(self.name, self.opts["max_iter"])
        nv, m = mech.nv, mech.m
        ws = self.ws
        self.row_buffers = kinematics.row_buffers(mech, ws)
        grp = np.array(mech.compiled.row_group, dtype=np.int64)
        gcnt = np.bincount(grp).astype(float)
        self._W = ManifoldWork(ws.q, ws.v, ws.drive_data.f, ws.data.M, ws.parent, ws.tau, ws.data.nle, ws.a, ws.lam,
                               np.arange(m, dtype=np.int64), np.zeros((nv, nv)), np.zeros((m, nv)), np.zeros((m, m)),
                               np.zeros((m, m)), np.zeros((m, m)), np.zeros((m, nv)), np.zeros(m, dtype=np.int64),
                               np.zeros(m), np.zeros(1, dtype=np.int64), np.zeros((m, nv)),
                               np.zeros(m, dtype=np.int64), np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(nv),
                               np.zeros(m), np.zeros(m), np.zeros(nv), np.zeros(nv), np.zeros(nv),
                               grp, gcnt, np.zeros(gcnt.size), np.zeros((m, m)), np.zeros((m, m)), np.zeros(m),
                               np.zeros(m), np.zeros((m, m)), np.zeros(m, dtype=np.int64),
                               np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), np.zeros(ws.q.shape[0]),
                               np.zeros(nv), np.zeros(ws.drive_data.f.shape), np.zeros(ws.q.shape[0]),
                               np.zeros(m), np.zeros(1, dtype=np.int64))
        self._stages = None

    @property
    def time_in_positions(self):
        return len(self.mech.drives) > 0    # the stages' projection onto the drives' rows

    @property
    def supports_projection(self):
        return self.mech.m > 0           # no rows: nothing to project onto

    def monitor(self):
        """Not watched: the formulation is made to pass singular (flat) configurations, where the
        pivots of its QR fall to rounding by design, and its code is 1 at every good evaluation;
        negative codes (M not positive definite, non-finite) reject the trial step."""
        return (0.0, -np.inf)

    # -------------------------------------------------------------- stages
    def _bound(self):
        """(projection at the stages, exact projection, solve) bound to the workspace; without
        rows the plain solve of M a = tau - nle (lagrange's kernel with no rows)."""
        if self._stages is None:
            mech, ws, o, W = self.mech, self.ws, self.opts, self._W
            if mech.m == 0:
                K = Solve(ws.q, ws.v, ws.drive_data.f, ws.data.M, ws.parent, ws.tau, ws.data.nle, W.rows, W.Lm, W.Y,
                          W.S, W.S, W.r, W.r, ws.a, ws.lam)
                self._stages = (None, None, bind(lagrange_accel, (self.row_buffers, K, 0.0, 0.0), code=True,
                                                 name=f"{self.name} solve"), None)
            else:
                P, keep = position_passes(self)
                args = (P, self.row_buffers, W, T, float(o["tol"]), o["max_iter"], float(o["rcond"]), float(o["mu"]),
                        float(o["rcond_v"]), chol_gate(o["tangent"]))
                self._stages = (bind(manifold_project, args + (0,), code=True, name=f"{self.name} projection P"),
                                bind(manifold_project, args + (1,), code=True, name=f"{self.name} projection"),
                                bind(projected_accelerations,
                                     (self.row_buffers, W, float(o["tangent"]), float(o["mu"])), code=True,
                                     name=f"{self.name} solve"), keep)
        return self._stages

    def compiled(self):
        """The projection P as a ``before`` stage (M and the joint placements are left at the
        projected q: mass=False, placements=False), the solve, the exact projection after steps
        (the drive values first: the run evaluates them before any ``before`` stage, the
        projection needs its own)."""
        before, exact, solve, _ = self._bound()
        if self.mech.m == 0:
            return Compiled(solve=(solve,))
        return Compiled(before=(before,), solve=(solve,), project=self.drive_stages() + (exact,), mass=False,
                        placements=False)

    # -------------------------------------------------------------- Python path (the same kernels)
    def project(self, t, q, v):
        if self.mech.m == 0:
            return q, v
        ws = self.ws
        ws.q[:], ws.v[:] = q, v
        self.drive_values(t)
        self._check(self._bound()[1](t), t)
        return ws.q.copy(), ws.v.copy()

    def accelerations(self, t, q, v, z):
        ws = self.ws
        ws.load_state(q, v, z)
        before, _, solve, _ = self._bound()
        if self.mech.m == 0:
            self.applied(t, ws.q, ws.v, ws.z)
        else:
            self.drive_values(t)
            self._check(before(t), t)
            # the dynamics pass at the projected state; P left M and its factor at q1
            self.applied(t, ws.q, ws.v, ws.z, mass=False)
        self.code = code = solve(t)
        self._check(code, t)
        return ws.a.copy()

    def _check(self, code, t):
        if code == ERROR:
            raise self.errors.pop()
        if code == RANK:
            raise np.linalg.LinAlgError(f"{self.mech.name}: the mass matrix is not positive definite at "
                                        f"t = {t:.9g} s (check the URDF inertias)")


# ------------------------------------------------------------------ kernels
@njit(cache=True, inline="always")
def manifold_project(P, R, W, t, tol, max_iter, rcond, mu, rcond_v, gate, exact):
    """(q, v) <- P(q, v) in the state buffer (module doc, steps 1-2): one minimum-norm
    Gauss-Newton step from q (``exact``: more while |Phi| > tol and each reduces it, at most
    max_iter; each iterate costs the position passes and the rows), then the mass matrix and the
    mass-metric velocity projection at q1 (``exact`` 0: the stages' filtered one; 1: the exact
    one after steps). Leaves M = L^T L, B = J L^-1, B^T's pivoted QR and the factor of
    S + i mu^2 I at q1 for projected_accelerations. Returns OK, RANK (M not positive definite)
    or ERROR."""
    q, zero = P.q, P.zero_v
    if exact and same_state(W, q) and row_residual(R.phi, W.rows) <= tol:
        # the state the step logic evaluated last (the accepted state of an FSAL step): its stage
        # projection took this very Gauss-Newton step from it, computed the rows at q1 and
        # factored M, B and S there, so the exact projection ends at q1 (|Phi| <= tol) and its
        # velocity comes from those factors: the same numbers as computing them again
        for i in range(q.shape[0]):
            q[i] = W.q1[i]
        P.steps[0] = 1
        W.last[0] = 2          # taken (read by the tests)
        exact_velocity(R, W)
        for c in range(W.v.shape[0]):
            W.v[c] = W.v1[c]
        return OK
    W.last[0] = 0
    if not exact:
        W.qin[:] = q
        W.vin[:] = W.v
        W.fin[:, :] = W.fdrv
    if at_positions(P, 0, t) == ERROR:
        return ERROR
    constraint_rows_positions(R, q, zero, W.fdrv)
    prev = row_residual(R.phi, W.rows) if exact else 0.0     # the stages never test it
    P.steps[0] = 0
    for _ in range(max_iter):
        min_norm_step_gram(R.Jc, R.phi, W.rows, R.cols, R.ncols, W.Gg, W.Lg, W.pg, W.dg, W.yg, W.Qg, W.pg, W.hg, W.r,
                           rcond, P.dq)
        if move(P, t) == ERROR or at_positions(P, 0, t) == ERROR:
            return ERROR
        P.steps[0] += 1
        constraint_rows_positions(R, q, zero, W.fdrv)
        if not exact:
            break          # the stages: one step (module doc, step 1)
        res = row_residual(R.phi, W.rows)
        if res <= tol or stalled(res, prev):
            break
        prev = res
    mass_only(P)
    if not velocity_projection(R, W, mu, rcond_v, gate, exact):
        return RANK
    for c in range(W.v.shape[0]):
        W.v[c] = W.v1[c]
    if not exact:
        W.q1[:] = q
        W.last[0] = 1
    return OK


@njit(cache=True, inline="always")
def same_state(W, q):
    """True if the buffers hold the stage projection of exactly this state: q, the state
    buffer's v and the drive values bitwise those of the last stage projection, with no
    projection since (W.last)."""
    if W.last[0] != 1:
        return False
    for i in range(q.shape[0]):
        if q[i] != W.qin[i]:
            return False
    for i in range(W.v.shape[0]):
        if W.v[i] != W.vin[i]:
            return False
    for r in range(W.fdrv.shape[0]):
        for k in range(W.fdrv.shape[1]):
            if W.fdrv[r, k] != W.fin[r, k]:
                return False
    return True


@njit(cache=True)
def _bt_times(Y, R, w, x):
    """x = B^T w (B = Y, the rows' supports in R: zero outside them, the same bits as the dense
    sum). From WIDE rows along the supports' runs of columns (support_runs_add, the same bits)."""
    x[:] = 0.0
    if Y.shape[0] >= WIDE:
        for j in range(Y.shape[0]):
            support_runs_add(x, Y[j], R.cols[j], R.ncols[j], w[j])
        return
    for j in range(Y.shape[0]):
        wj = w[j]
        for kk in range(R.ncols[j]):
            k = R.cols[j, kk]
            x[k] += Y[j, k] * wj


@njit(cache=True, inline="always")
def _rows_times(A, R, x, first, out):
    """out = first + A x over the rows' supports (R), each sum in the dense order from first."""
    for r in range(A.shape[0]):
        s = first[r]
        for kk in range(R.ncols[r]):
            k = R.cols[r, kk]
            s += A[r, k] * x[k]
        out[r] = s


def chol_gate(tangent):
    """The smallest pivot of S = B B^T, relative to its first, at which the solves take S's
    Cholesky factor instead of B^T's pivoted QR: the square of the ``tangent`` pivot, taken at
    least 1e-3, so the tangent correction near flat (projected_accelerations), which needs the
    QR's Q, never meets the Cholesky path, and the gate is at least 1e-6: S's solves are then
    accurate to ~eps / gate = 2e-10 relative or better."""
    return min(max(float(tangent), 1e-3), 1.0) ** 2


@njit(cache=True, inline="always")
def velocity_projection(R, W, mu, rcond, gate, exact):
    """At q (the rows at (q, v = 0) in R: Phi, J and the rates Phi_t; M there): M = L^T L,
    B = J L^-1 (in Y), S = B B^T and its pivoted Cholesky factor, or, where a pivot of S falls
    below ``gate`` (near flat or redundant rows), the pivoted QR of B^T; at the stages the
    factor of S + i mu^2 Lam (shifted_factor; kept for projected_accelerations); and the
    mass-metric projection v1 = L^-1 ((I - Q Q^T) L v - B^+ Phi_t) onto J v1 + Phi_t = 0
    (``exact``: after a step, where the drives' rates are O(1) and a filter would bias them; the
    step logic evaluates again after it, so no factor is needed; with S's factor
    v1 = L^-1 (x - B^T S^-1 (B x + Phi_t)), x = L v, the same in exact arithmetic) or
    v1 = v - L^-1 B^T g(S) (J v + Phi_t) (the stages' filtered correction of an O(error)
    residual). False if M is not PD; kk[0] = rank kept, chol[0] = which factor."""
    v, v1, Lm, Y = W.v, W.v1, W.Lm, W.Y
    if not ltl_factor(W.M, W.parent, Lm):
        return False
    Jc, dphi, pt = R.Jc, R.dphi, W.r
    m, nv = Jc.shape
    schur_complement(Lm, W.parent, Jc, W.rows, R.cols, R.ncols, Y, W.S)
    chol = chol_pivoted(W.S, W.pc, W.Lc, W.dg, gate) > 0.0
    W.chol[0] = 1 if chol else 0
    k = m
    if not chol:
        for r in range(m):
            for c in range(nv):
                W.Qr[r, c] = Y[r, c]
        k = qr_pivoted(W.Qr, W.piv, W.hb, rcond)
    W.kk[0] = k
    if exact:
        exact_velocity(R, W)
        return True
    _rows_times(Jc, R, v, dphi, pt)            # J v + Phi_t (the rows' rates are at v = 0)
    for c in range(nv):
        v1[c] = v[c]
    corr = W.xs
    # g(S) pt: by the series on S's Cholesky factor where it converges (far from flat), else by
    # the factor of S + i mu^2 Lam; the stages' solve takes the same route (W.filt)
    row_shifts(W.S, mu, W.grp, W.gcnt, W.gsum, W.dsh)
    W.filt[0] = 1 if chol and series_filtered(W.Lc, W.pc, W.dsh, pt, W.w, W.yr, W.yi, W.yg) else 0
    if not W.filt[0]:
        shifted_factor(W.S, mu, W.grp, W.gcnt, W.gsum, W.Fr, W.Fi)
        filtered_solve_ws(W.Fr, W.Fi, pt, W.w, W.yr, W.yi)
    _bt_times(Y, R, W.w, corr)                 # the normal correction B^T g(S) pt
    ltl_solve(Lm, W.parent, corr)
    for c in range(nv):
        v1[c] -= corr[c]
    return True


@njit(cache=True, inline="always")
def exact_velocity(R, W):
    """v1 = L^-1 ((I - Q Q^T) L v - B^+ Phi_t) from the factors velocity_projection left (S's
    Cholesky factor: v1 = L^-1 (x - B^T S^-1 (B x + Phi_t)), x = L v; else B^T's QR)."""
    v, v1, Lm, Y, pt = W.v, W.v1, W.Lm, W.Y, W.r
    m, nv = Y.shape
    k = W.kk[0]
    ltl_mul(Lm, W.parent, v, v1)              # x = L v
    # Phi_t: the rheonomic rows' own rates, -f'(t) of the drives (zero for closures)
    mc = m - R.iq.shape[0]
    rates = False
    for r in range(m):
        pt[r] = 0.0 if r < mc else -W.fdrv[1, r - mc]
        rates = rates or pt[r] != 0.0
    if W.chol[0]:
        w = W.w
        _rows_times(Y, R, v1, pt, w)           # B x + Phi_t
        chol_solve_pivoted(W.Lc, W.pc, w, W.yg, w)
        for r in range(m):
            wr = w[r]
            for kk in range(R.ncols[r]):
                c = R.cols[r, kk]
                v1[c] -= Y[r, c] * wr
    else:
        project_out(W.Qr, W.hb, k, v1)
        if rates:
            corr = W.xs
            min_norm_x(W.Qr, W.piv, W.hb, k, pt, corr)     # B^+ Phi_t
            for c in range(nv):
                v1[c] -= corr[c]
    ltl_solve(Lm, W.parent, v1)


@njit(cache=True)
def _unit_lv(Lm, parent, v, x):
    """x = L v / |L v| (the velocity in the coordinates where B = J L^-1 lives); False if v = 0."""
    ltl_mul(Lm, parent, v, x)
    n = 0.0
    for c in range(x.shape[0]):
        n += x[c] * x[c]
    if not n > 0.0:
        return False
    n = np.sqrt(n)
    for c in range(x.shape[0]):
        x[c] /= n
    return True


@njit(cache=True, inline="always")
def _qr_reaction(R, W, wtan, r, w, corr):
    """Near rank loss (B^T's pivoted QR, velocity_projection): W.a <- (I - Q Q^T) y with the
    tangent along the velocity (module doc, step 4), W.lam = g(S) gamma - S^+ B y (r = -B y,
    w = g(S) gamma), corr = B^T w (R: the rows' supports)."""
    a, lam, Y, Lm, parent, Qr, hb = W.a, W.lam, W.Y, W.Lm, W.parent, W.Qr, W.hb
    m, nv = Y.shape
    k = W.kk[0]
    min_norm_solve(Qr, W.piv, hb, k, r, W.xs, lam)
    for rr in range(m):
        lam[rr] += w[rr]
    along = k > 0 and abs(Qr[k - 1, k - 1]) < wtan * abs(Qr[0, 0])    # near flat only
    xt, wt = W.xt, W.wt
    if along:
        along = _unit_lv(Lm, parent, W.v, xt)
    ww = xy = 0.0
    if along:
        for c in range(nv):                    # x^T y before y's normal part is removed
            xy += xt[c] * a[c]
            wt[c] = xt[c]
        project_out(Qr, hb, k, wt)             # w = (I - Q Q^T) x
        for c in range(nv):
            ww += wt[c] * wt[c]
        along = ww > 0.5                       # x mostly tangent (else the velocity is not a guide)
    project_out(Qr, hb, k, a)
    if along:
        # range(Q) made orthogonal to x: z - w (w^T z) / |w|^2 + x (x^T y). A no-op in exact
        # arithmetic, where x is orthogonal to range(B^T); near flat it replaces the round-off
        # of the vanishing normal along the velocity (~1e-16 / sigma^2) by x^T y exactly
        wz = 0.0
        for c in range(nv):
            wz += wt[c] * a[c]
        wz /= ww
        for c in range(nv):
            a[c] += xy * xt[c] - wz * wt[c]
    _bt_times(Y, R, w, corr)                   # B^T g(S) gamma, g(S) gamma from the multipliers


@njit(cache=True, inline="always")
def projected_accelerations(R, W, wtan, mu):
    """Accelerations at a state on the manifold (pass at (q, v) done; L, B = Y, B^T's QR and the
    factor of S + i mu^2 I from velocity_projection at q):
        y = L^-T (tau - nle),   a = L^-1 ((I - Q Q^T) y + B^T g(S) gamma).
    Exact where g(S) = S^-1: then B^T S^-1 (gamma - B y) = B^T g gamma - Q Q^T y. The applied
    forces' part of the constraint reaction (Q Q^T y) is a projector, exact at any distance
    from the flat configuration; only the velocity-squared part gamma is filtered, the one
    whose round-off grows like 1/s^(3/2) near it. Multipliers: lam = g(S) gamma - S^+ B y.
    g(S) gamma by the route velocity_projection took (W.filt; mu: the filter's, for the factor
    if the series does not converge on gamma).
    Returns 1, or -2 when the accelerations are not finite."""
    # the velocity terms at (q, v); Phi, J and the frames' placements are those the projection
    # left at this q (the same numbers: the rows at q are not evaluated twice)
    constraint_rows_velocities(R, 0.0, 0.0, W.v, W.fdrv)
    a, lam, Y, Lm, parent = W.a, W.lam, W.Y, W.Lm, W.parent
    m, nv = Y.shape
    for c in range(nv):
        a[c] = W.tau[c] - W.nle[c]
    ltl_solve_t(Lm, parent, a)                 # y
    # multipliers of the same split: B^T lam = B^T g(S) gamma - Q Q^T y, i.e.
    # lam = g(S) gamma - (B B^T)^+ B y (the second by the QR of B^T, no normal equations)
    r = W.r
    for rr in range(m):
        s = 0.0
        for kk in range(R.ncols[rr]):
            c = R.cols[rr, kk]
            s -= Y[rr, c] * a[c]
        r[rr] = s
    w = W.w                                    # g(S) gamma, by the route the projection took
    if not (W.filt[0] and series_filtered(W.Lc, W.pc, W.dsh, R.gamma, w, W.yr, W.yi, W.yg)):
        if W.filt[0]:                          # the series did not converge on gamma: the factor
            shifted_factor(W.S, mu, W.grp, W.gcnt, W.gsum, W.Fr, W.Fi)
            W.filt[0] = 0
        filtered_solve_ws(W.Fr, W.Fi, R.gamma, w, W.yr, W.yi)
    corr = W.xs
    if W.chol[0]:
        # far from flat (velocity_projection): S^-1 from its Cholesky factor, and
        # (I - Q Q^T) y + B^T g(S) gamma = y + B^T lam in one product
        chol_solve_pivoted(W.Lc, W.pc, r, W.yg, lam)
        for rr in range(m):
            lam[rr] += w[rr]
        _bt_times(Y, R, lam, corr)
    else:
        _qr_reaction(R, W, wtan, r, w, corr)
    for c in range(nv):
        a[c] += corr[c]
    ltl_solve(Lm, parent, a)
    t = 0.0
    for c in range(nv):
        t += a[c]
    return 1.0 if np.isfinite(t) else -2.0
