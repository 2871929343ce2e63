"""Lagrange multipliers with Baumgarte stabilisation: the source papers' method, eq.
  [M J^T; J 0] [a; -lam] = [tau - b; gamma],  gamma = -(dJ v) - 2 alpha dPhi - beta^2 Phi,
solved by the Schur complement S = J M^-1 J^T (M by Cholesky). Defaults alpha = beta = 5
(paper 000). Rows found redundant at the initial configuration are dropped (reported)."""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve

from pinclear.core.call import NONFINITE
from pinclear.core.jit import njit
from pinclear.core.stage import bind
from pinclear.core.tree_solve import kkt_solve
from pinclear.dynamics.formulations.base import RANK_COND, Compiled, Formulation, Solve
from pinclear.model import kinematics
from pinclear.model.rows import constraint_rows_all

#: pivot ratio of the kept rows, relative to its start, below which the independent rows are
#: chosen again (before the singular-passage monitor's SINGULAR_DIP would stop the run)
RESELECT_DIP = 1e-2


@njit(cache=True)
def scatter_multipliers(kept, rows, lam):
    """lam over every row from the multipliers of the kept rows (zero for the dropped ones)."""
    lam[:] = 0.0
    for i in range(rows.shape[0]):
        lam[rows[i]] = kept[i]
    return np.inf


class Lagrange(Formulation):
    fills_rows = True       # the kernel evaluates every row before the solve
    name = "lagrange"
    options = {"alpha": 5.0, "beta": 5.0, "drop_redundant": True}

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        nv, m = mech.nv, mech.m
        ws = self.ws
        self._buf = {"Lm": np.zeros((nv, nv)), "Y": np.zeros((m, nv)), "S": np.zeros((m, m)),
                     "Ls": np.zeros((m, m)), "d": np.zeros(m), "r": np.zeros(m), "lam": np.zeros(m)}
        #: the frame-kinematics and constraint-row buffers every stage of the formulation reads
        self.row_buffers = kinematics.row_buffers(mech, ws)
        # the kept rows live in one buffer whose first len(rows) entries are the rows: choosing
        # them again (same count) rewrites it in place, so bound stages stay valid
        self._rows_all = np.arange(m, dtype=np.int64)
        self._stages = None

    def use_rows(self, independent):
        if self.opts["drop_redundant"]:
            k = len(independent)
            self._rows_all[:k] = independent
            self.rows = self._rows_all[:k]
            self._stages = None

    @property
    def _all_rows(self):
        return len(self.rows) == self.mech.m

    def monitor(self):
        dropped = self.opts["drop_redundant"] and not self._all_rows
        return (1.0 / RANK_COND, RESELECT_DIP if dropped else -np.inf)

    def reselect_rows(self, t):
        """The kept rows are losing rank while the full set may not be (a redundant row chosen at
        t0 becomes the independent one, as in Bricard's linkage): choose the independent rows
        again at the last evaluation's configuration (its Jacobian is in ws.J). Consistent
        redundant rows give the same accelerations whichever independent subset is solved, so
        the right-hand side stays continuous up to the Baumgarte terms of the exchanged rows."""
        mech = self.mech
        _, indep, _ = kinematics.rank_analysis(self.ws.J.copy(), mech.row_names())
        if len(indep) != len(self.rows) or np.array_equal(indep, self.rows):
            return False
        self.rows[:] = indep
        names = mech.row_names()
        self.row_changes.append((float(t), [names[i] for i in range(mech.m) if i not in set(indep)]))
        return True

    def baumgarte(self):
        return (self.opts["alpha"], self.opts["beta"])

    def compiled(self):
        if self._stages is None:
            ws, b = self.ws, self._buf
            al, be = self.baumgarte()
            lam = ws.lam if self._all_rows else b["lam"]
            K = Solve(ws.q, ws.v, ws.drive_data.f, ws.data.M, ws.parent, ws.tau, ws.data.nle, self.rows, b["Lm"],
                      b["Y"], b["S"], b["Ls"], b["d"], b["r"], ws.a, lam)
            solve = bind(lagrange_accel, (self.row_buffers, K, float(al), float(be)), code=True,
                         name=f"{self.name} solve")
            # the multipliers of every row (ws.lam) from the kept rows' (contract 2)
            scatter = () if self._all_rows else (bind(scatter_multipliers, (b["lam"], self.rows, ws.lam)),)
            self._stages = (solve,) + scatter
        return Compiled(solve=self._stages)

    def accelerations(self, t, q, v, z):
        ws = self.ws
        ws.load_state(q, v, z)
        self.applied(t, ws.q, ws.v, ws.z)
        self.drive_values(t)
        code = np.inf
        for stage in self.compiled().solve:
            code = min(code, stage(t))
        self.code = code
        if not code >= 1.0 / RANK_COND and code != NONFINITE:
            self.rank_loss(self._schur(code), t)
        return ws.a.copy()

    def _schur(self, ratio):
        """S = J M^-1 J^T over the kept rows: the kernel's own (ratio >= 0: it factorised M and
        formed S before S's Cholesky stopped), else from a fresh Cholesky of M."""
        if ratio >= 0.0:
            m = len(self.rows)
            return self._buf["S"][:m, :m]
        J = self.ws.J[self.rows]
        return J @ cho_solve(self.mass_factor(), J.T, check_finite=False)


@njit(cache=True)
def _finite_code(a, code):
    """code, or -2 (NONFINITE) when a is not finite."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i]
    return code if np.isfinite(s) else -2.0


@njit(cache=True, inline="always")
def lagrange_accel(R, K, alpha, beta):
    """Constraint rows + KKT solve of M a - J^T lam = tau - nle, J a = gamma over K.rows (R: Rows,
    K: Solve). Returns the pivot ratio of S's Cholesky (0: rank loss), -1 when M is not positive
    definite, -2 when the accelerations are not finite."""
    constraint_rows_all(R, alpha, beta, K.q, K.v, K.fdrv)
    a = K.a
    for i in range(a.shape[0]):
        a[i] = K.tau[i] - K.nle[i]
    ratio = kkt_solve(K.M, K.parent, a, R.Jc, R.gamma, K.rows, R.cols, R.ncols, K.Lm, K.Y, K.S, K.Ls, a,
                      K.lam)
    return _finite_code(a, ratio)
