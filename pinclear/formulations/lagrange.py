"""Lagrange multipliers with Baumgarte stabilisation: the source papers' method, eq.
  [M J^T; J 0] [a; -lam] = [tau - b; gamma],  gamma = -(dJ v) - 2 alpha dPhi - beta^2 Phi,
solved by the Schur complement S = J M^-1 J^T (M by Cholesky). Defaults alpha = beta = 5
(paper 000). Rows found redundant at the initial configuration are dropped (reported)."""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve

from .. import kinematics
from .._kernels import lagrange_accel
from .base import RANK_COND, Formulation


class Lagrange(Formulation):
    name = "lagrange"
    options = {"alpha": 5.0, "beta": 5.0, "drop_redundant": True}
    checks_finite = True

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        nv, m = mech.nv, mech.m
        self._buf = {"Lm": np.zeros((nv, nv)), "Y": np.zeros((m, nv)), "S": np.zeros((m, m)),
                     "Ls": np.zeros((m, m)), "a": np.zeros(nv), "lam": np.zeros(m)}
        self._args = None       # kernel arguments, bound once (rows may be reset by the simulator)
        self.ratio_min = np.inf  # smallest pivot ratio of S since the simulator last reset it
        self.ratio_ref = None    # pivot ratio at the first evaluation (scale of the monitor)

    def baumgarte(self):
        return (self.opts["alpha"], self.opts["beta"])

    def accelerations(self, t, q, v, z):
        self.applied(t, q, v, z)
        ws, mech = self.ws, self.mech
        if self._args is None or self._args[-8] is not self.rows:
            b = self._buf
            al, be = self.baumgarte()
            self._args = kinematics.static_args(mech, ws) + (
                float(al), float(be), ws.data.M, ws.parent, ws.tau, ws.data.nle, self.rows,
                b["Lm"], b["Y"], b["S"], b["Ls"], b["a"], b["lam"])
        ratio = lagrange_accel(*self._args, q, v, mech.driverows.values(t))
        b = self._buf
        self.nonfinite = ratio == -2.0        # checked by the simulator (trial stages may overflow)
        if self.nonfinite:
            return b["a"].copy()
        if self.ratio_ref is None and ratio > 0:
            self.ratio_ref = ratio
        self.ratio_min = min(self.ratio_min, ratio)
        if ratio < 1.0 / RANK_COND:
            J = ws.J[self.rows]
            MiJt = cho_solve(self.mass_factor(), J.T, check_finite=False)
            self.rank_loss(J @ MiJt, t)
        if len(self.rows) == mech.m:
            ws.lam[:] = b["lam"]
        else:
            ws.lam[:] = 0.0
            ws.lam[self.rows] = b["lam"][: len(self.rows)]
        return b["a"].copy()
