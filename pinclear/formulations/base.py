"""One small base class for all forward-dynamics formulations (after SciPy's OdeSolver):
a formulation maps (t, q, v, z) to accelerations and multipliers; the simulator does the rest."""
from __future__ import annotations

import abc

import numpy as np
from scipy.linalg import cho_factor

from .. import kinematics
from ..errors import InputError, RankLossError

#: condition number of the constraint Schur complement beyond which a plain solve is garbage
RANK_COND = 1e12

#: a step whose Schur-complement pivot ratio dips below this fraction of its initial value may
#: have stepped over a singular configuration (see Formulation.pivot_dip)
SINGULAR_DIP = 1e-3


class Formulation(abc.ABC):
    """Base class of the forward-dynamics formulations, chosen by ``name``.

    The contract (the simulator relies on nothing else):

    1. ``Formulation(mech, **options)`` accepts exactly the keys of the class attribute
       ``options`` (name -> default); any other key is an InputError naming the valid ones. The
       object owns one workspace ``self.ws`` (a formulation serves one run in one thread).
    2. :meth:`accelerations` ``(t, q, v, z) -> a`` returns the joint accelerations (nv,) and
       leaves the multipliers of every constraint row (closures, then drives) in ``ws.lam`` and
       the internal-state rates of the force elements in ``ws.zdot``. Sign convention:
       ``M a + b = tau + J^T lam``.
    3. :meth:`finite` says whether the last evaluation was finite. A trial stage of an explicit
       integrator may overflow in a stiff contact; the simulator rejects it rather than stopping.
    4. A configuration the formulation cannot pass (rank loss of the constraint Jacobian) raises
       RankLossError with the time, the rank and the condition number.
    5. Capabilities are declared, not probed:
       - ``supports_projection``: :meth:`project` ``(t, q, v) -> (q, v)`` puts a state back on the
         constraint manifold; the simulator calls it after every accepted step and on samples.
       - :meth:`use_rows` receives the independent rows found at the initial configuration; a
         formulation that needs a full-rank Schur complement keeps only those, and may choose
         them again during the run (recorded in ``row_changes``) when the kept rows lose rank.
       - :meth:`pivot_dip` / :meth:`reset_pivot_monitor`: a formulation that watches the pivots
         of its constraint solve reports when they dipped during a step, so the simulator can
         search the step for a singular configuration it may have jumped over.
    6. :meth:`describe` returns a JSON-safe mapping of the method and its options (saved with runs).
    """

    name = "base"
    options: dict = {}                    # option name -> default
    supports_projection = False
    #: whether accelerations() leaves the workspace's kinematics pass (kinematics.update) at
    #: (q, v) in ws.data, which outputs, energies and residuals of the samples read; if not, the
    #: trajectory runs that pass itself
    fills_workspace = True
    #: whether accelerations() also leaves ws.phi, the residual of every closure and drive row at
    #: (t, q), so outputs need not evaluate the rows again
    fills_rows = False

    def __init__(self, mech, **options):
        bad = set(options) - set(self.options)
        if bad:
            raise InputError(f"method {self.name!r} has no option {sorted(bad)[0]!r}", choices=self.options)
        self.mech = mech
        # the sidecar's ``baumgarte:`` gains (those of the model's source paper) replace the
        # class defaults; options passed to simulate() replace both
        gains = {k: float(v) for k, v in (mech.sidecar.get("baumgarte") or {}).items() if k in self.options}
        self.opts = {**self.options, **gains, **options}
        self.ws = mech.workspace()
        self.rows = np.arange(mech.m, dtype=np.int64)      # constraint rows used (redundant ones may be dropped)
        self.row_changes = []              # (t, names of the rows dropped from then on), when re-chosen
        self._last_finite = True

    # -------------------------------------------------------------- shared pieces
    def applied(self, t, q, v, z, mass=True):
        """Kinematics pass and applied forces into ws.tau; fills ws.zdot for internal states
        (``mass=False``: data.M already holds the mass matrix at q, see kinematics.update)."""
        mech, ws = self.mech, self.ws
        kinematics.update(mech, ws, q, v, mass)
        if mech.forces:                   # tau stays zero otherwise
            apply_forces(mech, ws, t, q, v, z)

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
    @abc.abstractmethod
    def accelerations(self, t, q, v, z):
        """Return a (nv,); leave multipliers in ws.lam and internal-state rates in ws.zdot."""

    def finite(self, a) -> bool:
        """Whether the last evaluation (which returned ``a``) was finite."""
        return bool(np.isfinite(a.sum()))

    def project(self, t, q, v):
        return q, v

    def use_rows(self, independent):
        """Rows found independent at the initial configuration (default: keep every row)."""

    def pivot_dip(self) -> bool:
        """True when the constraint solve's pivots dipped during the current step."""
        return False

    def reset_pivot_monitor(self):
        """Start watching the pivots afresh (called after every step)."""

    def pivot_ratio(self) -> float:
        """Smallest pivot ratio of the constraint solve since the last reset (inf: not watched)."""
        return np.inf

    def describe(self) -> dict:
        return {"method": self.name, **self.opts}


def apply_forces(mech, ws, t, q, v, z):
    """Sum every force element's generalized force into ws.tau and its state rates into ws.zdot
    (kinematics already updated at (q, v))."""
    tau, zdot = ws.tau, ws.zdot
    tau.fill(0.0)
    for f, d, sl in zip(mech.forces, ws.force_data, mech.z_slices):
        f.add_force(mech, ws, d, t, q, v, z[sl], tau, zdot[sl])
