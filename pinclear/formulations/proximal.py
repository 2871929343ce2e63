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
from scipy.linalg import cho_factor, cho_solve

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
        return project_to_manifold(self, t, q, v, self.opts["tol"], self.opts["max_iter"])

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
        # rho relative to the scale of S keeps the iteration well conditioned for any units
        rho = self.opts["rho"] * max(np.trace(S) / len(S), 1e-300)
        cf = cho_factor(S + rho * np.eye(len(S)), lower=True, check_finite=False)
        lam = np.zeros(len(S))
        scale = max(np.linalg.norm(r), 1e-300)
        prev = np.inf
        for _ in range(self.opts["max_iter"]):
            res = r - S @ lam
            nres = np.linalg.norm(res)
            # stop when consistent to tol, or when the residual stalls (inconsistent rows)
            if nres <= self.opts["tol"] * scale or nres > 0.999 * prev:
                break
            prev = nres
            lam += cho_solve(cf, res, check_finite=False)
        ws.lam[:] = lam
        return a_free + MiJt @ lam
