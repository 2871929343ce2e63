"""One small base class for all forward-dynamics formulations (after SciPy's OdeSolver):
a formulation maps (t, q, v, z) to accelerations and multipliers; the simulator does the rest."""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor

from .. import kinematics
from ..errors import InputError, RankLossError

#: condition number of the constraint Schur complement beyond which a plain solve is garbage
RANK_COND = 1e12


class Formulation:
    name = "base"
    options: dict = {}                    # option name -> default
    supports_projection = False
    checks_finite = False                 # True: accelerations() sets self.nonfinite itself
    nonfinite = False

    def __init__(self, mech, **options):
        bad = set(options) - set(self.options)
        if bad:
            raise InputError(f"method {self.name!r} has no option {sorted(bad)[0]!r} "
                             f"(valid: {', '.join(sorted(self.options)) or 'none'})")
        self.mech = mech
        self.opts = {**self.options, **options}
        self.ws = mech.workspace()
        self.rows = np.arange(mech.m)      # constraint rows used (redundant ones may be dropped)

    # -------------------------------------------------------------- shared pieces
    def applied(self, t, q, v, z):
        """Kinematics pass and applied forces into ws.tau; fills ws.zdot for internal states."""
        mech, ws = self.mech, self.ws
        ws.q_cur = q
        kinematics.update(mech, ws, q, v)
        if mech.forces:                   # tau stays zero otherwise
            tau = ws.tau
            tau[:] = 0.0
            for f, sl in zip(mech.forces, mech.z_slices):
                f.add_force(mech, ws, t, q, v, z[sl], tau, ws.zdot[sl])

    def mass_factor(self):
        """Cholesky of M (upper triangle of data.M is what crba fills)."""
        return cho_factor(self.ws.data.M, lower=False, check_finite=False)

    def rank_loss(self, S, t):
        sv = np.linalg.svd(S, compute_uv=False)
        tol = sv[0] / RANK_COND
        rank = int(np.sum(sv > tol))
        raise RankLossError(
            f"{self.mech.name}: constraint Jacobian lost rank at t = {t:.6g} s (rank {rank} of "
            f"{S.shape[0]} rows, condition {sv[0] / max(sv[-1], 1e-300):.3g}); method {self.name!r} cannot "
            "continue through a singular or redundant configuration: use method='proximal'",
            t=t, rank=rank, rows=S.shape[0], cond=float(sv[0] / max(sv[-1], 1e-300)))

    # -------------------------------------------------------------- interface
    def accelerations(self, t, q, v, z):
        """Return a (nv,); leave multipliers in ws.lam and internal-state rates in ws.zdot."""
        raise NotImplementedError

    def project(self, t, q, v):
        return q, v

    def describe(self) -> dict:
        return {"method": self.name, **self.opts}
