"""Pieces shared by the mechanism generators: mass properties of tubes, cylinders and U-joint
crosses, URDF text, sidecar writing, and an independent closed-chain solver (ClosedChain) that
the tests use as a second method beside pinclear.model.closures."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.core.models import models_dir

STEEL = 7850.0       # kg/m^3
ALUMINIUM = 2700.0   # kg/m^3
URDF_DIR = models_dir()        # where the generators write (the bundled models)


def cylinder_inertia(rho, length, r_out, r_in=0.0):
    """Mass and central inertia (axis along local x) of a tube / solid cylinder."""
    m = rho * math.pi * (r_out**2 - r_in**2) * length
    i_ax = 0.5 * m * (r_out**2 + r_in**2)
    i_tr = m * (3 * (r_out**2 + r_in**2) + length**2) / 12.0
    return m, np.diag([i_ax, i_tr, i_tr])


def axis_inertia(I_x, axis):
    """Rotate a central inertia given with its symmetry axis along x onto ``axis``."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    R = pin.Quaternion.FromTwoVectors(np.array([1.0, 0, 0]), axis).matrix()
    return R @ I_x @ R.T


def cross_inertia(axis1, axis2, rho, d, length):
    """U-joint spider: two crossed pins along axis1 and axis2 (overlap neglected)."""
    m1, I1 = cylinder_inertia(rho, length, d / 2)
    return 2 * m1, axis_inertia(I1, axis1) + axis_inertia(I1, axis2)


def u_angles(d, e1, e2, zero_dir):
    """Angles (a, b) with Rot(e1, a) Rot(e2, b) zero_dir = d  (e1, e2, zero_dir orthonormal)."""
    s = float(np.dot(np.cross(e2, zero_dir), e1))     # e2 x zero_dir = s e1, s = +-1
    b = math.asin(max(-1.0, min(1.0, s * float(np.dot(d, e1)))))
    w = np.cross(e1, zero_dir)
    a = math.atan2(float(np.dot(d, w)), float(np.dot(d, zero_dir)))
    return a, b



def write_sidecar_yaml(path, d, head):
    """Write a generated sidecar; a ``clearances:`` block already in the file is kept (it is
    edited by hand or by the clearance scenes, not by the generator)."""
    import yaml

    path = Path(path)
    if path.exists():
        old = yaml.safe_load(path.read_text()) or {}
        if old.get("clearances"):
            d["clearances"] = old["clearances"]
    path.write_text(head + yaml.safe_dump(d, sort_keys=False, default_flow_style=None, width=110))


class ClosedChain:
    """Closure equations of a URDF tree written directly on Pinocchio frame kinematics,
    independently of pinclear.model.closures (used for forward position analysis and as a
    cross-check of the core). Supports spherical, universal, prismatic (closure conventions
    of pinclear.model.closures: axes are the frames' z axes, prismatic frames aligned)."""

    def __init__(self, model, closures, drive_joints=()):
        self.model = model
        self.data = model.createData()
        self.closures = [(c["type"], model.getFrameId(c["frame1"]), model.getFrameId(c["frame2"]))
                         for c in closures]
        self.drive_idx = [model.joints[model.getJointId(j)].idx_v for j in drive_joints]
        self.drive_iq = [model.joints[model.getJointId(j)].idx_q for j in drive_joints]

    def residual_jacobian(self, q, targets=None):
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        res, jac = [], []
        for kind, f1, f2 in self.closures:
            M1, M2 = data.oMf[f1], data.oMf[f2]
            J1 = pin.getFrameJacobian(model, data, f1, pin.LOCAL_WORLD_ALIGNED)
            J2 = pin.getFrameJacobian(model, data, f2, pin.LOCAL_WORLD_ALIGNED)
            R1, R2 = M1.rotation, M2.rotation
            if kind in ("spherical", "universal"):
                res.append(M1.translation - M2.translation)
                jac.append(J1[:3] - J2[:3])
            if kind == "universal":
                z1, z2 = R1[:, 2], R2[:, 2]
                res.append([z1 @ z2])
                jac.append((np.cross(z1, z2) @ (J1[3:] - J2[3:]))[None])
            if kind == "prismatic":
                # orientation error as a rotation vector (exact Jacobian through Jlog3)
                Rrel = R1.T @ R2
                res.append(pin.log3(Rrel))
                jac.append(pin.Jlog3(Rrel) @ R2.T @ (J2[3:] - J1[3:]))
                d = M2.translation - M1.translation
                for ax in (0, 1):
                    u = R1[:, ax]
                    res.append([u @ d])
                    jac.append((u @ (J2[:3] - J1[:3]) + np.cross(u, d) @ J1[3:])[None])
        if targets is not None:
            e = np.zeros((len(self.drive_idx), model.nv))
            for k, (iv, iq) in enumerate(zip(self.drive_idx, self.drive_iq)):
                e[k, iv] = 1.0
            res.append(q[self.drive_iq] - np.asarray(targets))
            jac.append(e)
        return np.concatenate([np.ravel(r) for r in res]), np.vstack(jac)

    def solve(self, q, targets=None, tol=1e-13, max_iter=50):
        """Newton (Gauss-Newton on non-square systems) from q; raises if it does not converge."""
        q = np.array(q, float)
        for _ in range(max_iter):
            r, J = self.residual_jacobian(q, targets)
            if np.max(np.abs(r)) < tol:
                return q
            dq = np.linalg.lstsq(J, -r, rcond=None)[0]
            q = pin.integrate(self.model, q, dq)
        r, _ = self.residual_jacobian(q, targets)
        if np.max(np.abs(r)) < 1e-10:
            return q
        from pinclear.core.errors import AssemblyError
        raise AssemblyError(f"closed-chain Newton did not converge: |residual| = {np.max(np.abs(r)):.3e}")


def solve_lengths(model, closures, drive_joints, lengths, q0, frame="platform"):
    """Forward position analysis of a platform: the closed-chain configuration whose driven
    joints have ``lengths``, by Newton from q0. Returns (q, world pose of ``frame``)."""
    ch = ClosedChain(model, closures, drive_joints)
    q = ch.solve(q0, targets=lengths)
    pin.framesForwardKinematics(model, ch.data, q)
    return q, pin.SE3(ch.data.oMf[model.getFrameId(frame)])


def config_vector(model, values):
    q = pin.neutral(model)
    for name, val in values.items():
        q[model.joints[model.getJointId(name)].idx_q] = val
    return q
