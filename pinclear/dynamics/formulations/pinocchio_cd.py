"""Pinocchio's own constrained dynamics (pin.constraintDynamics, proximal solver) on the same
tree. Closures must map onto Pinocchio's rigid constraints: spherical -> CONTACT_3D,
weld -> CONTACT_6D. Drives are added on top by a Schur complement: the joint accelerations
are affine in the drive forces, a = a0 + K lam_d, so lam_d solves E K lam_d = gamma_d - E a0."""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinclear.core.errors import InputError, RankLossError
from pinclear.dynamics.formulations.base import Formulation
from pinclear.model.closures import PINOCCHIO_TYPES


def rigid_constraints(mech, alpha=0.0, beta=0.0):
    """pin.RigidConstraintModel list equivalent to the mechanism's closures (or InputError)."""
    model = mech.model
    bad = [c for c in mech.closures if c.type not in PINOCCHIO_TYPES]
    if bad:
        raise InputError(
            f"method 'pinocchio' cannot express closure {bad[0].name!r} of type {bad[0].type!r}: "
            f"Pinocchio's rigid constraints cover {', '.join(sorted(PINOCCHIO_TYPES))} only "
            "(use lagrange, projection or proximal)")
    models = []
    for c in mech.closures:
        F1, F2 = model.frames[c.f1], model.frames[c.f2]
        cm = pin.RigidConstraintModel(getattr(pin.ContactType, PINOCCHIO_TYPES[c.type]), model,
                                      F1.parentJoint, F1.placement, F2.parentJoint, F2.placement,
                                      pin.LOCAL)
        cm.name = c.name
        if alpha or beta:
            # same stabilisation law as lagrange: Kp = beta^2, Kd = 2 alpha
            cm.setBaumgarteCorrectorParameters(pin.BaumgarteCorrectorParameters(beta * beta, 2.0 * alpha))
        models.append(cm)
    return models


class PinocchioCD(Formulation):
    name = "pinocchio"
    options = {"alpha": 5.0, "beta": 5.0, "mu": 1e-12, "accuracy": 1e-12, "max_iter": 50}

    def __init__(self, mech, **options):
        super().__init__(mech, **options)
        self.cmodels = pin.StdVec_RigidConstraintModel()
        for cm in rigid_constraints(mech, self.opts["alpha"], self.opts["beta"]):
            self.cmodels.append(cm)
        self.cdatas = pin.StdVec_RigidConstraintData()
        for cm in self.cmodels:
            self.cdatas.append(cm.createData())
        self.data = mech.model.createData()
        pin.initConstraintDynamics(mech.model, self.data, self.cmodels, self.cdatas)
        self.prox = pin.ProximalSettings(self.opts["accuracy"], self.opts["mu"], self.opts["max_iter"])
        self.nd = len(mech.drives)
        self._tau = np.zeros(mech.nv)     # applied forces plus the drive forces being solved for

    def use_rows(self, independent):
        """Refuse closure rows found redundant at the start: Pinocchio's rigid constraints take a
        closure whole (3 or 6 rows), so a redundant row cannot be dropped, and its proximal
        solver at mu = 1e-12 does not converge on them (Cassie's planar plantar loops stop it at
        t = 0 with a residual of 7; benchmarks/bench_cassie.md)."""
        names = self.mech.compiled.row_names
        keep = set(int(i) for i in independent)
        redundant = [names[i] for i in range(len(names)) if i not in keep]
        if redundant:
            raise InputError(f"'pinocchio' cannot run {self.mech.name}: closure rows {', '.join(redundant)} are "
                             f"redundant at the start (rank {len(names) - len(redundant)} of {len(names)}) and "
                             "Pinocchio's rigid constraints take each closure whole; use lagrange, projection, "
                             "proximal or manifold", key="method")

    @property
    def fills_workspace(self):
        # Pinocchio's constraintDynamics runs on its own data; ws.data sees the state only
        # through applied(), i.e. when there are force elements
        return bool(self.mech.forces)

    def _cd(self, q, v, tau):
        return pin.constraintDynamics(self.mech.model, self.data, q, v, tau, self.cmodels, self.cdatas, self.prox)

    def accelerations(self, t, q, v, z):
        mech, ws = self.mech, self.ws
        tau = self._tau
        if mech.forces:
            self.applied(t, q, v, z)
            tau[:] = ws.tau
        else:
            tau[:] = 0.0
        a0 = self._cd(q, v, tau).copy()
        if self.prox.iter >= self.opts["max_iter"]:
            self._not_converged(t)
        mc = mech.compiled.m
        if self.nd:
            dr = mech.driverows
            phi, dphi, ddf = dr.rows(t, q, v, ws.drive_data)
            g = ddf - 2.0 * self.opts["alpha"] * dphi - self.opts["beta"] ** 2 * phi
            K = np.empty((mech.nv, self.nd))
            for k, iv in enumerate(dr.iv):
                tau[iv] += 1.0
                K[:, k] = self._cd(q, v, tau) - a0
                tau[iv] -= 1.0
            EK = K[dr.iv]
            try:
                lam_d = np.linalg.solve(EK, g - a0[dr.iv])
            except np.linalg.LinAlgError:
                lam_d = None
            if lam_d is None or not np.all(np.isfinite(lam_d)) or np.linalg.cond(EK) > 1e12:
                raise RankLossError(f"{mech.name}: drives lost rank at t = {t:.6g} s (the drive map "
                                    f"E K has condition {np.linalg.cond(EK):.3g})", t=t)
            ws.lam[mc:] = lam_d
            tau[dr.iv] += lam_d
            a = self._cd(q, v, tau).copy()
        else:
            a = a0
        # Pinocchio gives each constraint's force in its own frame (joint1 placement, LOCAL);
        # rotate to world axes so multipliers compare across formulations
        lf = np.asarray(self.data.lambda_c).ravel()
        r = 0
        for cm in self.cmodels:
            n = cm.residualSize()
            R = (self.data.oMi[cm.joint1_id] * cm.joint1_placement).rotation
            ws.lam[r:r + 3] = R @ lf[r:r + 3]
            if n == 6:
                ws.lam[r + 3:r + 6] = R @ lf[r + 3:r + 6]
            r += n
        return a

    def _not_converged(self, t):
        raise RankLossError(f"{self.mech.name}: Pinocchio's proximal solver did not converge at t = {t:.6g} s "
                            f"in {self.opts['max_iter']} iterations (residual {self.prox.absolute_residual:.3g})",
                            t=t)
