"""Robust formulation: ``max_iter`` proximal (regularised) iterations on the multipliers,
  (S + rho I) lam_{k+1} = r + rho lam_k,   S = J M^-1 J^T,   lam_0 = 0,
a fixed number of them, so the right-hand side is a smooth function of the state (one Cholesky
factor of S + rho I and its inverse, then one matrix-vector product per iteration:
pinclear.core.regularised.proximal_iterations). They handle redundant rows (lam not unique, accelerations
unique) and give a bounded, least-squares-like acceleration where gamma is inconsistent (singular
configurations): the part of lam along null(J^T) does not reach the accelerations. Baumgarte as
in lagrange; positions and velocities are projected after every step with the same filter
(pinclear.dynamics.formulations.projection.project_state). rho is relative to the mean diagonal of S
(default 1e-4; the parallelogram study in tests/model/test_core_fourbar.py shows 1e-6 already makes a
singular passage depend on rounding). The solve is one compiled kernel
(pinclear.dynamics.formulations.proximal.proximal_accel), tested against the NumPy expression
:func:`proximal_multipliers`.

The iteration count is fitted to the start (``max_iter`` 'auto', the default;
:meth:`Proximal.fit_start`): k iterations leave the fraction (rho / (s + rho))^k of the constraint
force along an eigen-direction s of S, so a mechanism whose independent rows are nearly dependent
(s well below rho) had its constraint force cut by a fixed k = 30 and reported success with the
wrong motion (three_upru_up: velocity 4.6e-4 off at rtol 1e-10; cassie.sdf: the shin triangles
flexed). k is raised until that fraction is <= rtol on every independent direction at the start;
a direction that would need more than MAX_ITER_AUTO iterations is not held by this method at all,
and the run is refused, naming its rows.

With ``max_iter`` given, the user's count is kept; when it leaves more than rtol of a direction's
force unapplied, the run ends **failed** (``FailureKind.UNAPPLIED``, samples kept): Cassie at
max_iter = 50, rtol = 1e-6 kept its closure residual at 2e-8 (the projection puts the state
back) while its knee-shin joints flexed by 1e-3 rad, and reported success. ``unapplied="record"``
is the explicit opt-out: the run keeps its status and ``stats["unapplied_force"]`` records the
shortfall."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin

from pinclear.core.call import RANK
from pinclear.core.errors import InputError
from pinclear.core.jit import njit
from pinclear.core.regularised import proximal_filter, relative_rho
from pinclear.core.stage import T, bind
from pinclear.core.tree_solve import ltl_factor, ltl_solve, ltl_solve_t, schur_complement
from pinclear.dynamics.formulations.base import Compiled, Formulation, Solve
from pinclear.dynamics.formulations.lagrange import _finite_code
from pinclear.dynamics.formulations.projection import (
    RCOND,
    iterations,
    position_passes,
    project_state,
    projector,
    run_projection,
)
from pinclear.model import kinematics
from pinclear.model.rows import constraint_rows_all


class Proximal(Formulation):
    fills_rows = True       # the kernel evaluates every row before the solve
    name = "proximal"
    options = {"alpha": 5.0, "beta": 5.0, "rho": 1e-4, "max_iter": "auto", "tol": 1e-12, "project": True,
               "unapplied": "fail"}
    #: what a run with too few iterations for its rtol does (module doc)
    UNAPPLIED = ("fail", "record")
    #: fewest iterations (the count used before it was fitted: well-conditioned mechanisms keep it,
    #: and with it their results)
    MIN_ITER = 30
    #: most iterations 'auto' may choose; a start needing more is refused (module doc)
    MAX_ITER_AUTO = 2000

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        if self.opts["unapplied"] not in self.UNAPPLIED:
            raise InputError(f"method 'proximal': option 'unapplied' must be one of {', '.join(self.UNAPPLIED)}, got "
                             f"{self.opts['unapplied']!r}", key="unapplied", choices=self.UNAPPLIED)
        self.auto = isinstance(self.opts["max_iter"], str) and self.opts["max_iter"] == "auto"
        self.opts["max_iter"] = self.MIN_ITER if self.auto else iterations(self.name, self.opts["max_iter"])
        #: (smallest independent eigenvalue of S over rho, force fraction left by the filter) at the start
        self.start_filter = None
        #: the start's shortfall when a given max_iter leaves more than rtol of a force unapplied
        self.shortfall = None
        nv, m = mech.nv, mech.m
        ws = self.ws
        self.row_buffers = kinematics.row_buffers(mech, ws)
        self._K = Solve(ws.q, ws.v, ws.drive_data.f, ws.data.M, ws.parent, ws.tau, ws.data.nle,
                        np.arange(m, dtype=np.int64), np.zeros((nv, nv)), np.zeros((m, nv)), np.zeros((m, m)),
                        np.zeros((m, m)), np.zeros(m), np.zeros(m), ws.a, ws.lam)
        self._solve = self._projection = None

    def fit_start(self, t, q, J, independent, rtol):
        """The iteration count from the start's conditioning (module doc): the smallest k >=
        MIN_ITER with (rho / (s + rho))^k <= rtol for every eigenvalue s of S = J M^-1 J^T that
        belongs to the independent rows (the rank of J: redundant directions carry no force and
        are the filter's purpose). With max_iter given, the user's count is kept and a count too
        small is a warning; with 'auto', a need beyond MAX_ITER_AUTO refuses the run."""
        if self.mech.m == 0 or not independent:
            return
        M = pin.crba(self.mech.model, self.ws.data, np.asarray(q, float))
        M = np.triu(M) + np.triu(M, 1).T
        S = J @ np.linalg.solve(M, J.T)
        rho = float(self.opts["rho"]) * float(np.mean(np.diag(S)))
        w, U = np.linalg.eigh(S)
        keep = slice(len(w) - len(independent), len(w))       # the rank's largest eigenvalues
        s, U = np.maximum(w[keep], 0.0), U[:, keep]
        per_iter = -np.log1p(s / rho)                          # log of rho / (s + rho), per direction
        k = self.opts["max_iter"]
        needs = np.log(rtol) / np.minimum(per_iter, -1e-300)   # iterations each direction needs
        need = float(needs.max())
        self.start_filter = (float(s[0] / rho), float(np.exp(k * per_iter[0])))
        if need <= k:
            return
        short = needs > (self.MAX_ITER_AUTO if self.auto else k)     # the directions the message is about
        rows = ", ".join(self.row_names_along(U[:, short], np.arange(self.mech.m)))
        what = (f"{self.mech.name}: method 'proximal' at t = {t:.6g} s: the independent rows {rows} combine to an "
                f"eigenvalue {s[0] / rho:.3g} x rho of J M^-1 J^T, along which {k} proximal iterations leave "
                f"{self.start_filter[1]:.3g} of the constraint force unapplied (rtol {rtol:g} needs "
                f"{min(need, 1e300):.3g} iterations)")
        if not self.auto:
            self.shortfall = {"t": float(t), "rows": rows, "max_iter": int(k), "force_left": self.start_filter[1],
                              "rtol": float(rtol), "iterations_needed": min(need, 1e300),
                              "message": what + "; raise max_iter or use method='manifold'"}
            if self.opts["unapplied"] == "record":
                warnings.warn(self.shortfall["message"], RuntimeWarning, stacklevel=3)
        elif need > self.MAX_ITER_AUTO:
            raise InputError(what + f", more than {self.MAX_ITER_AUTO}: this method does not hold these rows; use "
                             "method='manifold'", key="method")
        else:
            self.opts["max_iter"] = k = max(k, math.ceil(need))
            self.start_filter = (self.start_filter[0], float(np.exp(k * per_iter[0])))
            self._solve = self._projection = None

    @property
    def supports_projection(self):
        return bool(self.opts["project"]) and self.mech.m > 0

    def monitor(self):
        """Not watched: the proximal iterations pass singular and redundant configurations by
        design (the code is 1 at every good evaluation, so the pivots say nothing); negative
        codes (M not positive definite, non-finite) reject the trial step."""
        return (0.0, -np.inf)

    def solve_stage(self):
        if self._solve is None:
            o = self.opts
            self._solve = bind(proximal_accel, (self.row_buffers, self._K, float(o["alpha"]), float(o["beta"]),
                                                float(o["rho"]), o["max_iter"]), code=True, name=f"{self.name} solve")
        return self._solve

    def projection_stage(self):
        """The bound projection kernel: Gauss-Newton and velocity steps through the same filter."""
        if self._projection is None:
            P, keep = position_passes(self)
            W = projector(self, self._K.rows)
            o = self.opts
            self._projection = (bind(project_state, (P, self.row_buffers, W, T, float(o["tol"]), o["max_iter"], RCOND,
                                                     o["max_iter"], float(o["rho"])), code=True,
                                     name=f"{self.name} projection"), keep)
        return self._projection[0]

    def compiled(self):
        project = ()
        if self.supports_projection:
            project = self.drive_stages() + (self.projection_stage(),)
        return Compiled(solve=(self.solve_stage(),), project=project)

    def accelerations(self, t, q, v, z):
        ws = self.ws
        ws.load_state(q, v, z)
        self.applied(t, ws.q, ws.v, ws.z)
        self.drive_values(t)
        self.code = code = self.solve_stage()(t)
        if code == RANK:
            raise np.linalg.LinAlgError(f"{self.mech.name}: the mass matrix is not positive definite at "
                                        f"t = {t:.9g} s (check the URDF inertias)")
        return ws.a.copy()

    def check_run(self, traj) -> bool:
        """A given max_iter that left more than rtol of a constraint force unapplied at the start
        (:meth:`fit_start`) fails the run, samples kept, unless ``unapplied="record"``."""
        from pinclear.core.failures import Failure, FailureKind

        if self.shortfall is None:
            return False
        sf = self.shortfall
        traj.stats["unapplied_force"] = {k: v for k, v in sf.items() if k != "message"}
        if self.opts["unapplied"] == "record" or traj.status != "success":
            return False
        traj.status = "failed"
        end = f"{traj.t[-1]:.6g}" if len(traj.t) else f"{sf['t']:.6g}"
        traj.message = (f"constraint force unapplied: {sf['message']} (option unapplied='record' keeps the run and "
                        f"records this; samples kept up to t = {end} s)")
        traj.failure = Failure(FailureKind.UNAPPLIED, sf["t"], traj.message)
        return True

    def describe(self) -> dict:
        out = super().describe()
        if self.start_filter is not None:
            out["start_filter"] = {"eigenvalue_over_rho": self.start_filter[0], "force_left": self.start_filter[1]}
        return out

    def project(self, t, q, v):
        if not self.supports_projection:
            return q, v
        return run_projection(self, self.projection_stage(), t, q, v)


def proximal_multipliers(S, r, rho, k):
    """The multipliers after k proximal iterations (S + rho I) lam_{i+1} = r + rho lam_i from
    lam_0 = 0, in closed form: lam = V diag(f(s)) V^T r over the eigenpairs (s, V) of S with the
    filter f(s) = (1 - (rho / (s + rho))^k) / s (limit k / rho at s = 0). The NumPy reference
    the compiled iterations are tested against.

    Why a fixed k: stopping the iteration on its residual made the right-hand side a
    discontinuous function of the state, so an adaptive integrator's steps, and the accuracy of a
    singular passage, depended on the machine's rounding. The filter is a smooth function of S;
    it equals S^-1 to (rho / (s + rho))^k where S is well conditioned, and caps the response of
    the directions whose eigenvalue drops below rho / k near a singular or redundant
    configuration."""
    s, V = np.linalg.eigh(S)
    s = np.maximum(s, 0.0)                  # S is positive semi-definite; drop rounding below 0
    x = rho / (s + rho)
    small = s < 1e-9 * rho
    f = np.where(small, k / rho, -np.expm1(k * np.log(np.where(small, 0.5, x))) / np.where(small, 1.0, s))
    return V @ (f * (V.T @ r))


@njit(cache=True, inline="always")
def proximal_accel(R, K, alpha, beta, rho_rel, k):
    """Constraint rows + the proximal solve over K.rows (every row) (R: Rows, K: Solve): M = L^T L,
    Y = L^-T J^T, S = Y^T Y = J M^-1 J^T, lam = filter(S) (gamma - J M^-1 f),
    a = M^-1 (f + J^T lam), f = tau - nle. Returns 1, -1 when M is not positive definite, -2
    when the result is not finite."""
    constraint_rows_all(R, alpha, beta, K.q, K.v, K.fdrv)
    a, Y, rows = K.a, K.Y, K.rows
    nv, m = a.shape[0], rows.shape[0]
    if not ltl_factor(K.M, K.parent, K.Lm):
        return -1.0
    for i in range(nv):
        a[i] = K.tau[i] - K.nle[i]
    ltl_solve_t(K.Lm, K.parent, a)                 # a = y_f = L^-T f
    if m > 0:
        schur_complement(K.Lm, K.parent, R.Jc, rows, R.cols, R.ncols, Y, K.S)
        r = K.r
        for i in range(m):
            s = R.gamma[rows[i]]
            for c in range(nv):
                s -= Y[i, c] * a[c]
            r[i] = s                             # gamma - J M^-1 f
        proximal_filter(K.S, r, relative_rho(K.S, rho_rel), k, K.Ls, K.d, K.lam)
        for i in range(m):
            li = K.lam[i]
            for c in range(nv):
                a[c] += Y[i, c] * li
    ltl_solve(K.Lm, K.parent, a)
    return _finite_code(a, 1.0)
