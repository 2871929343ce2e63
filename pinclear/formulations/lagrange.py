"""Lagrange multipliers with Baumgarte stabilisation: the source papers' method, eq.
  [M J^T; J 0] [a; -lam] = [tau - b; gamma],  gamma = -(dJ v) - 2 alpha dPhi - beta^2 Phi,
solved by the Schur complement S = J M^-1 J^T (M by Cholesky). Defaults alpha = beta = 5
(paper 000). Rows found redundant at the initial configuration are dropped (reported)."""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve

from .. import kinematics
from .base import Formulation


class Lagrange(Formulation):
    name = "lagrange"
    options = {"alpha": 5.0, "beta": 5.0, "drop_redundant": True}

    def baumgarte(self):
        return (self.opts["alpha"], self.opts["beta"])

    def accelerations(self, t, q, v, z):
        f = self.applied(t, q, v, z)
        ws, mech = self.ws, self.mech
        if mech.m == 0:
            a = cho_solve(self.mass_factor(), f, check_finite=False)
            return a
        kinematics.constraint_rows(mech, ws, t, v, self.baumgarte())
        rows = self.rows
        J = ws.J if len(rows) == mech.m else ws.J[rows]
        g = ws.gamma if len(rows) == mech.m else ws.gamma[rows]
        c = self.mass_factor()
        MiJt = cho_solve(c, J.T, check_finite=False)
        a_free = cho_solve(c, f, check_finite=False)
        lam = self.schur_solve(J @ MiJt, g - J @ a_free, t)
        ws.lam[:] = 0.0
        ws.lam[rows] = lam
        return a_free + MiJt @ lam
