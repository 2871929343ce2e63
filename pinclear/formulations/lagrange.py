"""Lagrange multipliers with Baumgarte stabilisation: the source papers' method, eq.
  [M J^T; J 0] [a; -lam] = [tau - b; gamma],  gamma = -(dJ v) - 2 alpha dPhi - beta^2 Phi,
solved by the Schur complement S = J M^-1 J^T (M by Cholesky). Defaults alpha = beta = 5
(paper 000). Rows found redundant at the initial configuration are dropped (reported)."""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve

from .. import kinematics
from .._bind import DYN, bind
from .._kernels import lagrange_accel
from .base import RANK_COND, SINGULAR_DIP, Formulation

#: pivot ratio of the kept rows, relative to its start, below which the independent rows are
#: chosen again (before the singular-passage monitor's SINGULAR_DIP would stop the run)
RESELECT_DIP = 1e-2


class Lagrange(Formulation):
    fills_rows = True       # the kernel evaluates every row before the solve
    name = "lagrange"
    options = {"alpha": 5.0, "beta": 5.0, "drop_redundant": True}

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        nv, m = mech.nv, mech.m
        self._buf = {"Lm": np.zeros((nv, nv)), "Y": np.zeros((m, nv)), "S": np.zeros((m, m)),
                     "Ls": np.zeros((m, m)), "a": np.zeros(nv), "lam": np.zeros(m)}
        self._a = self._buf["a"]
        self._args = None       # kernel arguments, bound once (rows may be reset by the simulator)
        self._bound_rows = None
        self._drive_values = mech.driverows.values
        self._drive_data = self.ws.drive_data
        self._ratio_floor = 1.0 / RANK_COND
        self.ratio_min = np.inf  # smallest pivot ratio of S since the simulator last reset it
        self.ratio_ref = None    # pivot ratio at the first evaluation (scale of the monitor)
        self.nonfinite = False

    def use_rows(self, independent):
        if self.opts["drop_redundant"]:
            self.rows = np.array(independent, dtype=np.int64)

    def _reselect_rows(self, t):
        """The kept rows are losing rank while the full set may not be (a redundant row chosen at
        t0 becomes the independent one, as in Bricard's linkage): choose the independent rows
        again at this configuration. Consistent redundant rows give the same accelerations
        whichever independent subset is solved, so the right-hand side stays continuous up to
        the Baumgarte terms of the exchanged rows. Returns True when the rows changed."""
        mech = self.mech
        _, indep, _ = kinematics.rank_analysis(self.ws.J.copy(), mech.row_names())
        if len(indep) != len(self.rows) or np.array_equal(indep, self.rows):
            return False
        self.rows = np.array(indep, dtype=np.int64)
        names = mech.row_names()
        self.row_changes.append((float(t), [names[i] for i in range(mech.m) if i not in set(indep)]))
        self._bind()
        return True

    def finite(self, a):
        return not self.nonfinite

    def pivot_dip(self):
        return self.ratio_ref is not None and self.ratio_min < SINGULAR_DIP * self.ratio_ref

    def reset_pivot_monitor(self):
        self.ratio_min = np.inf

    def pivot_ratio(self):
        return self.ratio_min

    def baumgarte(self):
        return (self.opts["alpha"], self.opts["beta"])

    def _bind(self):
        """Kernel arguments, bound once: every array is a persistent buffer or a view of
        Pinocchio's data. With all rows kept the kernel writes the multipliers into ws.lam."""
        ws, mech, b = self.ws, self.mech, self._buf
        al, be = self.baumgarte()
        self._all_rows = len(self.rows) == mech.m
        self._dropped = self.opts["drop_redundant"] and not self._all_rows
        lam = ws.lam if self._all_rows else b["lam"]
        self._bound_rows = self.rows
        self._args = kinematics.static_args(mech, ws) + (
            float(al), float(be), ws.data.M, ws.parent, ws.tau, ws.data.nle, self.rows,
            b["Lm"], b["Y"], b["S"], b["Ls"], b["a"], lam)
        self._kernel = bind(lagrange_accel, self._args + (DYN, DYN, DYN))

    def accelerations(self, t, q, v, z):
        self.applied(t, q, v, z)
        if self._bound_rows is not self.rows:
            self._bind()
        ratio = self._kernel(q, v, self._drive_values(t, self._drive_data))
        if (self._dropped and self.ratio_ref is not None and 0.0 <= ratio < RESELECT_DIP * self.ratio_ref
                and self._reselect_rows(t)):
            ratio = self._kernel(q, v, self._drive_values(t, self._drive_data))
        a = self._a.copy()
        self.nonfinite = ratio == -2.0        # read by finite() (trial stages may overflow)
        if ratio < self._ratio_floor:
            if self.nonfinite:
                return a
            self.rank_loss(self._schur(ratio), t)
        if ratio < self.ratio_min:
            self.ratio_min = ratio
            if self.ratio_ref is None:
                self.ratio_ref = ratio
        if not self._all_rows:
            ws = self.ws
            ws.lam[:] = 0.0
            ws.lam[self.rows] = self._buf["lam"][: len(self.rows)]
        return a

    def _schur(self, ratio):
        """S = J M^-1 J^T over the kept rows: the kernel's own (ratio >= 0: it factorised M and
        formed S before S's Cholesky stopped), else from a fresh Cholesky of M."""
        if ratio >= 0.0:
            m = len(self.rows)
            return self._buf["S"][:m, :m]
        J = self.ws.J[self.rows]
        return J @ cho_solve(self.mass_factor(), J.T, check_finite=False)
