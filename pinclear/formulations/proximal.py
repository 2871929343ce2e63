"""Robust formulation: ``max_iter`` proximal (regularised) iterations on the multipliers,
  (S + rho I) lam_{k+1} = r + rho lam_k,   S = J M^-1 J^T,   lam_0 = 0,
a fixed number of them, so the right-hand side is a smooth function of the state (one Cholesky
factor of S + rho I and its inverse, then one matrix-vector product per iteration:
pinclear._kernels.proximal_iterations). They handle redundant rows (lam not unique, accelerations
unique) and give a bounded, least-squares-like acceleration where gamma is inconsistent (singular
configurations): the part of lam along null(J^T) does not reach the accelerations. Baumgarte as
in lagrange; positions and velocities are projected after every step with the same filter
(pinclear.formulations.projection.project_state). rho is relative to the mean diagonal of S
(default 1e-4; the parallelogram study in tests/test_core_fourbar.py shows 1e-6 already makes a
singular passage depend on rounding). The solve is one compiled kernel
(pinclear._kernels.proximal_accel), tested against the NumPy expression
:func:`proximal_multipliers`."""
from __future__ import annotations

import numpy as np

from .. import kinematics
from .._kernels import Solve, proximal_accel
from ..stepping.call import RANK
from ..stepping.stage import T, bind
from .base import Compiled, Formulation
from .projection import RCOND, iterations, position_passes, project_state, projector, run_projection


class Proximal(Formulation):
    fills_rows = True       # the kernel evaluates every row before the solve
    name = "proximal"
    options = {"alpha": 5.0, "beta": 5.0, "rho": 1e-4, "max_iter": 30, "tol": 1e-12, "project": True}

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        self.opts["max_iter"] = iterations(self.name, self.opts["max_iter"])
        nv, m = mech.nv, mech.m
        ws = self.ws
        self.row_buffers = kinematics.row_buffers(mech, ws)
        self._K = Solve(ws.q, ws.v, ws.drive_data.f, ws.data.M, ws.parent, ws.tau, ws.data.nle,
                        np.arange(m, dtype=np.int64), np.zeros((nv, nv)), np.zeros((m, nv)), np.zeros((m, m)),
                        np.zeros((m, m)), np.zeros(m), np.zeros(m), ws.a, ws.lam)
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
