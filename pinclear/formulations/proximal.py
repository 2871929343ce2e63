"""Robust formulation: ``max_iter`` proximal (regularised) iterations on the multipliers,
  (S + rho I) lam_{k+1} = r + rho lam_k,   S = J M^-1 J^T,   lam_0 = 0,
evaluated in closed form (one eigendecomposition of S, see proximal_multipliers), so the
right-hand side is a smooth function of the state. They handle redundant rows (lam not unique,
accelerations unique) and give a bounded, least-squares-like acceleration where gamma is
inconsistent (singular configurations): the part of lam along null(J^T) does not reach the
accelerations. Baumgarte as in lagrange; positions and velocities are projected after every step
with the same filter. rho is relative to the mean diagonal of S (default 1e-4; the parallelogram
study in tests/test_core_fourbar.py shows 1e-6 already makes a singular passage depend on
rounding). The multipliers and accelerations are computed by one compiled kernel
(pinclear._kernels.proximal_accel), tested against the NumPy expression below."""
from __future__ import annotations

import numpy as np

from .. import kinematics
from .._bind import DYN, bind
from .._kernels import proximal_accel
from .base import Formulation
from .projection import project_to_manifold


class Proximal(Formulation):
    fills_rows = True       # the kernel evaluates every row before the solve
    name = "proximal"
    options = {"alpha": 5.0, "beta": 5.0, "rho": 1e-4, "max_iter": 30, "tol": 1e-12, "project": True}

    @property
    def supports_projection(self):
        return bool(self.opts["project"])

    def project(self, t, q, v):
        def solve(A, b):         # the same smooth filter as the multipliers (see proximal_multipliers)
            rho = self.opts["rho"] * max(np.trace(A) / len(A), 1e-300)
            return proximal_multipliers(A, b, rho, self.opts["max_iter"])

        return project_to_manifold(self, t, q, v, self.opts["tol"], self.opts["max_iter"], solve)

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        nv, m = mech.nv, mech.m
        ws = self.ws
        self._buf = {"Lm": np.zeros((nv, nv)), "Y": np.zeros((m, nv)), "S": np.zeros((m, m)), "r": np.zeros(m),
                     "a": np.zeros(nv)}
        b = self._buf
        self._args = kinematics.static_args(mech, ws) + (
            float(self.opts["alpha"]), float(self.opts["beta"]), ws.data.M, ws.parent, ws.tau, ws.data.nle,
            np.arange(m, dtype=np.int64), b["Lm"], b["Y"], b["S"], b["r"], b["a"], ws.lam, float(self.opts["rho"]), float(self.opts["max_iter"]))
        self._kernel = bind(proximal_accel, self._args + (DYN, DYN, DYN))
        self._values = mech.driverows.values
        self._nonfinite = False

    def finite(self, a):
        return not self._nonfinite

    def accelerations(self, t, q, v, z):
        self.applied(t, q, v, z)
        code = self._kernel(q, v, self._values(t, self.ws.drive_data))
        self._nonfinite = code == -2.0
        if code == -1.0:
            raise np.linalg.LinAlgError(f"{self.mech.name}: the mass matrix is not positive definite at "
                                        f"t = {t:.9g} s (check the URDF inertias)")
        return self._buf["a"].copy()


def proximal_multipliers(S, r, rho, k):
    """The multipliers after k proximal iterations (S + rho I) lam_{i+1} = r + rho lam_i from
    lam_0 = 0, in closed form: lam = V diag(f(s)) V^T r over the eigenpairs (s, V) of S with the
    filter f(s) = (1 - (rho / (s + rho))^k) / s (limit k / rho at s = 0).

    Why closed form and a fixed k: stopping the iteration on its residual made the right-hand
    side a discontinuous function of the state, so an adaptive integrator's steps, and the
    accuracy of a singular passage, depended on the machine's rounding. The filter is a smooth
    function of S; it equals S^-1 to (rho / (s + rho))^k where S is well conditioned, and caps
    the response of the directions whose eigenvalue drops below rho / k near a singular or
    redundant configuration."""
    s, V = np.linalg.eigh(S)
    s = np.maximum(s, 0.0)                  # S is positive semi-definite; drop rounding below 0
    x = rho / (s + rho)
    small = s < 1e-9 * rho
    f = np.where(small, k / rho, -np.expm1(k * np.log(np.where(small, 0.5, x))) / np.where(small, 1.0, s))
    return V @ (f * (V.T @ r))
