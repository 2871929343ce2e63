"""One small base class for all forward-dynamics formulations (after SciPy's OdeSolver):
a formulation maps (t, q, v, z) to accelerations and multipliers; the simulator does the rest."""
from __future__ import annotations

import abc
from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_factor

from pinclear.core.call import ERROR, OK
from pinclear.core.errors import InputError, RankLossError
from pinclear.model import kinematics

#: condition number of the constraint Schur complement beyond which a plain solve is garbage
RANK_COND = 1e12



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
    3. A non-finite evaluation leaves the code NONFINITE (contract 7). A trial stage of an
       explicit integrator may overflow in a stiff contact; the step logic rejects it rather
       than stopping.
    4. A configuration the formulation cannot pass (rank loss of the constraint Jacobian) raises
       RankLossError with the time, the rank and the condition number from
       :meth:`accelerations` (its compiled solve returns the code RANK or a ratio below the
       monitor's floor).
    5. Capabilities are declared, not probed:
       - ``supports_projection``: :meth:`project` ``(t, q, v) -> (q, v)`` puts a state back on the
         constraint manifold; the simulator calls it after every accepted step and on samples.
       - :meth:`use_rows` receives the independent rows found at the initial configuration; a
         formulation that needs a full-rank Schur complement keeps only those, and may choose
         them again during the run (recorded in ``row_changes``) when the kept rows lose rank
         (contract 8).
       - :meth:`fit_start` receives the start state, its constraint Jacobian (closures, then
         drives), the independent rows and the run's rtol, once before the run; a formulation
         whose accuracy depends on the start's conditioning sets its options from them there
         (the proximal method's iteration count) or refuses the run.
    6. :meth:`describe` returns a JSON-safe mapping of the method and its options (saved with runs).
    7. Compiled evaluation. :meth:`compiled` returns the formulation's stages
       (pinclear.core.stage: kernels bound to the workspace's buffers), which the run calls
       from compiled step logic, or None when it has no compiled form (the run then calls
       :meth:`accelerations` through a Python stage, at Python's cost):
       - ``before``: stages run before Pinocchio's passes (they may rewrite the state buffer's
         q and v: the manifold method's projection);
       - ``solve``: stages run after the force elements and the drive laws (the state in
         ``ws.q``, ``ws.v``, ``ws.z``, the passes' results in ``ws.data``, the applied forces
         in ``ws.tau``, the drive values in ``ws.drive_data.f``): they write the
         accelerations into ``ws.a`` and every row's multiplier into ``ws.lam``; the last
         returns the evaluation's code (pinclear.core.call: the pivot ratio of the
         constraint solve, OK when not watched, RANK or NONFINITE);
       - ``project``: the projection of the state buffer's (q, v) onto the constraint manifold
         (``supports_projection``), returning a code (negative: failed);
       - ``mass``: whether Pinocchio's passes must compute the mass matrix;
       - ``placements``: whether the run computes the joint placements the kernels read
         (``ws.fk``) after the passes; False when the ``before`` stages leave them at the
         evaluated q (the manifold method's projection ends at its q).
       The Python path computes the same thing with the same kernels on the same buffers:
       :meth:`accelerations` leaves the evaluation's code in ``self.code`` and raises
       RankLossError where the code says rank loss, :meth:`project` moves (q, v) as the
       ``project`` stages do.
    8. The pivot monitor (pinclear.dynamics.stepping.checks) runs in the step logic on the codes:
       :meth:`monitor` gives its rank floor (a code below it is a bad evaluation) and reselect
       factor (a ratio below it times the run's first asks :meth:`reselect_rows` to choose the
       independent rows again at the state of the last evaluation; -inf: never).
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
    #: whether accelerations() depends on t through the positions it evaluates at (the manifold
    #: method projects every evaluation onto the drives' rows Phi(q, t) = 0): an implicit
    #: integrator's secant test then needs df/dt (pinclear.dynamics.stepping.rosenbrock.jacobian)
    time_in_positions = False

    #: the code of the last evaluation of :meth:`accelerations` (contract 7)
    code = OK

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
        #: exceptions of Python stages inside the formulation's own stages (a Python drive law
        #: the projection evaluates, placements of a tree the compiled chain does not cover)
        self.errors = []
        self._drives = None

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
        # S = J M^-1 J^T over the kept rows is symmetric: its eigenvectors of the eigenvalues
        # below sv_max / RANK_COND are the row combinations that (nearly) vanish; the rows that
        # carry them are named, so that the user sees which closure is (nearly) redundant
        w, U = np.linalg.eigh(S)
        sv = np.abs(w)[::-1]
        tol = sv[0] / RANK_COND
        rank = int(np.sum(sv > tol))
        rows = self.row_names_along(U[:, np.abs(w) <= tol])
        cond = float(sv[0] / max(sv[-1], 1e-300))
        raise RankLossError(
            f"{self.mech.name}: constraint Jacobian lost rank at t = {t:.6g} s (rank {rank} of "
            f"{S.shape[0]} rows, condition {cond:.3g}"
            + (f"; nearly dependent rows: {', '.join(rows)}" if rows else "")
            + f"); method {self.name!r} cannot continue through a singular or redundant configuration: use "
            "method='manifold' (it holds nearly dependent rows) or 'proximal' (it passes singular configurations)", t=t, rank=rank, rows=S.shape[0], cond=cond)

    def drive_stages(self) -> tuple:
        """The drive law stages on this workspace (pinclear.model.drives.DriveRows.stages), built once:
        the formulation's own stages that need the drive values at their time (the projections)
        run them first. Their Python stages report to ``self.errors``."""
        if self._drives is None:
            self._drives = self.mech.driverows.stages(self.ws.drive_data, self.errors)
        return self._drives

    def drive_values(self, t):
        """The drive values at t (``ws.drive_data.f``) for the Python path, through the run's own
        drive stages: the same kernels as the compiled run and no per-time cache, which a
        compiled stage writing the values would leave stale (DriveRows.values keeps one)."""
        for stage in self.drive_stages():
            if stage(t) == ERROR:
                raise self.errors.pop()
        return self.ws.drive_data.f

    # -------------------------------------------------------------- interface
    @abc.abstractmethod
    def accelerations(self, t, q, v, z):
        """Return a (nv,); leave multipliers in ws.lam and internal-state rates in ws.zdot."""

    def project(self, t, q, v):
        return q, v

    def use_rows(self, independent):
        """Rows found independent at the initial configuration (default: keep every row)."""

    def fit_start(self, t, q, J, independent, rtol):
        """Options set from the start state (contract 5); default: nothing to fit."""

    def row_names_along(self, U, rows=None):
        """Names of the rows that carry the row combinations U[:, k] (the columns of U, over
        ``rows``, default the kept rows), largest share first: the rows a user looks at."""
        rows = self.rows if rows is None else rows
        weight = (np.asarray(U) ** 2).sum(axis=1)
        names = self.mech.row_names()
        return [names[rows[i]] for i in np.argsort(-weight)[:6] if weight[i] > 0.01]

    def compiled(self):
        """The formulation's compiled stages (contract 7); None: none."""
        return None

    def monitor(self):
        """(rank floor, reselect factor) of the pivot monitor (contract 8). By default the
        pivots are not watched, but a negative code (RANK, NONFINITE: pinclear.core.call)
        is a failed evaluation, whose trial step the step logic rejects (contract 3)."""
        return (0.0, -np.inf)

    def reselect_rows(self, t) -> bool:
        """Choose the independent constraint rows again at the last evaluation's state
        (contract 8); True when they changed."""
        return False

    def check_run(self, traj) -> bool:
        """After the run: a formulation that knows its result is not held to the run's tolerance
        marks ``traj`` failed (samples kept, a named :class:`~pinclear.core.failures.Failure`) or,
        where the user opted out, records it in ``traj.stats``. True if it failed the run."""
        return False

    def describe(self) -> dict:
        return {"method": self.name, **self.opts}


class Compiled(NamedTuple):
    """A formulation's compiled stages (Formulation contract 7)."""
    before: tuple = ()
    solve: tuple = ()
    project: tuple = ()
    mass: bool = True
    placements: bool = True


def apply_forces(mech, ws, t, q, v, z):
    """Sum every force element's generalized force into ws.tau and its state rates into ws.zdot
    (kinematics already updated at (q, v))."""
    tau, zdot = ws.tau, ws.zdot
    tau.fill(0.0)
    for f, d, sl in zip(mech.forces, ws.force_data, mech.z_slices):
        f.add_force(mech, ws, d, t, q, v, z[sl], tau, zdot[sl])


class Solve(NamedTuple):
    """The buffers of a constraint solve (lagrange, projection, proximal): the state and drive
    values it reads, Pinocchio's M and nle, the applied forces, the rows solved for, work arrays
    and the outputs (a, and lam over ``rows``)."""
    q: np.ndarray
    v: np.ndarray
    fdrv: np.ndarray     # (3, nd) drive law values and derivatives at t
    M: np.ndarray        # data.M (upper triangle)
    parent: np.ndarray   # parent dof (-1 at roots)
    tau: np.ndarray      # applied generalized forces
    nle: np.ndarray      # data.nle
    rows: np.ndarray     # (k,) the rows solved for
    Lm: np.ndarray       # (nv, nv) M = L^T L
    Y: np.ndarray        # (m, nv) L^-T J^T, row-wise
    S: np.ndarray        # (m, m) J M^-1 J^T
    Ls: np.ndarray       # (m, m) Cholesky of S (lagrange) or of S + rho I (proximal)
    d: np.ndarray        # (m,) reciprocal pivots of the proximal factor
    r: np.ndarray        # (m,) work
    a: np.ndarray        # (nv,) accelerations
    lam: np.ndarray      # (k,) multipliers of ``rows``
