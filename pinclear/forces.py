"""Force elements: anything that adds a generalized force computed from the state.

Springs, applied joint forces and clearance contacts share this interface, so the formulations
never special-case them. See docs/design.md for the contract.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from .timelaws import TimeLaw

LWA = pin.LOCAL_WORLD_ALIGNED


class ForceElement:
    name: str = ""
    nz: int = 0
    conservative: bool = True
    events: list = []

    def z0(self, mech, ws, q, v):
        return np.zeros(self.nz)

    def add_force(self, mech, ws, t, q, v, z, tau, zdot):
        raise NotImplementedError

    def potential(self, mech, ws, q) -> float:
        return 0.0

    def power_loss(self, mech, ws, t, q, v, z) -> float:
        return 0.0

    def outputs(self, mech, ws, t, q, v, z) -> dict:
        return {}

    def event_value(self, k, mech, ws, t, q, v, z) -> float:
        raise NotImplementedError

    def handle_event(self, k, mech, ws, t, q, v, z):
        return z

    def describe(self) -> dict:
        return {"name": self.name, "type": type(self).__name__}


class SpringDamper(ForceElement):
    """Point-to-point spring-damper between two frames: F = k (|d| - L0) + c d|d|/dt along d."""

    def __init__(self, name, f1, f2, k, c=0.0, free_length=0.0):
        self.name, self.f1, self.f2 = name, int(f1), int(f2)
        self.k, self.c, self.L0 = float(k), float(c), float(free_length)
        self.conservative = self.c == 0.0

    def _geometry(self, mech, ws):
        data = ws.data
        d = data.oMf[self.f1].translation - data.oMf[self.f2].translation
        L = float(np.linalg.norm(d))
        n = d / L if L > 0 else np.zeros(3)
        J1 = pin.getFrameJacobian(mech.model, data, self.f1, LWA)[:3]
        J2 = pin.getFrameJacobian(mech.model, data, self.f2, LWA)[:3]
        return L, n, J1 - J2

    def add_force(self, mech, ws, t, q, v, z, tau, zdot):
        L, n, Jd = self._geometry(mech, ws)
        Ldot = float(n @ (Jd @ v))
        f = self.k * (L - self.L0) + self.c * Ldot       # tension
        tau -= f * (Jd.T @ n)

    def potential(self, mech, ws, q):
        L = np.linalg.norm(ws.data.oMf[self.f1].translation - ws.data.oMf[self.f2].translation)
        return 0.5 * self.k * (L - self.L0) ** 2

    def power_loss(self, mech, ws, t, q, v, z):
        L, n, Jd = self._geometry(mech, ws)
        Ldot = float(n @ (Jd @ v))
        return self.c * Ldot * Ldot

    def outputs(self, mech, ws, t, q, v, z):
        L, n, Jd = self._geometry(mech, ws)
        Ldot = float(n @ (Jd @ v))
        return {"length": np.array(L), "force": np.array(self.k * (L - self.L0) + self.c * Ldot)}

    def describe(self):
        return {"name": self.name, "type": "spring_damper", "k": self.k, "c": self.c, "free_length": self.L0}


class JointForce(ForceElement):
    """Applied generalized force/torque on a 1-DoF joint following a time law."""

    conservative = False

    def __init__(self, name, idx_v, law: TimeLaw):
        self.name, self.idx_v, self.law = name, int(idx_v), law

    def add_force(self, mech, ws, t, q, v, z, tau, zdot):
        tau[self.idx_v] += self.law.eval(t)[0]

    def power_loss(self, mech, ws, t, q, v, z):
        # negative loss = power injected
        return -self.law.eval(t)[0] * v[self.idx_v]

    def outputs(self, mech, ws, t, q, v, z):
        return {"force": np.array(self.law.eval(t)[0])}

    def describe(self):
        return {"name": self.name, "type": "joint_force", "law": self.law.describe()}
