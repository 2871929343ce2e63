"""Robust formulation: proximal (regularised) iterations on the multipliers,
  (S + rho I) lam_{k+1} = r + rho lam_k,   S = J M^-1 J^T,
which converge for redundant rows (lam not unique, accelerations unique) and give the
least-squares acceleration where gamma is inconsistent (singular configurations): the part of
lam that grows along null(J^T) does not reach the accelerations. Baumgarte as in lagrange.
rho (relative to the mean diagonal of S) = 1e-4: smaller values let a parallelogram jump to its
anti-parallelogram branch at the flat configuration (measured: rho 1e-12 switched at t = 1.37 s,
1e-4 follows the one-degree-of-freedom pendulum it must be), larger ones slow convergence."""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve

from .. import kinematics
from .base import Formulation
from .projection import project_to_manifold


class Proximal(Formulation):
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

    def accelerations(self, t, q, v, z):
        self.applied(t, q, v, z)
        f = self.ws.tau - self.ws.data.nle
        ws, mech = self.ws, self.mech
        c = self.mass_factor()
        a_free = cho_solve(c, f, check_finite=False)
        if mech.m == 0:
            return a_free
        kinematics.constraint_rows(mech, ws, t, q, v, (self.opts["alpha"], self.opts["beta"]))
        J, g = ws.J, ws.gamma
        MiJt = cho_solve(c, J.T, check_finite=False)
        S = J @ MiJt
        r = g - J @ a_free
        # rho relative to the scale of S keeps the filter well defined for any units
        rho = self.opts["rho"] * max(np.trace(S) / len(S), 1e-300)
        ws.lam[:] = proximal_multipliers(S, r, rho, self.opts["max_iter"])
        return a_free + MiJt @ ws.lam


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
