"""A spring and damper on a 1-dof joint: tau = -k (q - reference) - c v (an SDF joint's
<dynamics> spring_stiffness, spring_reference and damping; an MJCF joint's stiffness, springref
and damping). Sidecar form::

    - {name: knee.spring, type: joint_spring, joint: knee, k: 1500.0, c: 0.1, reference: 0.0}

Potential 1/2 k (q - reference)^2, power loss c v^2 (the energy audit, pinclear.dynamics.energy);
conservative when c = 0. Compiled (ForceElement contract 10): :func:`joint_spring_force`.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.jit import njit
from pinclear.core.registry import Key, PluginType
from pinclear.model.forces import ForceElement


@njit(cache=True)
def joint_spring_force(iq, iv, k, c, ref, q, v, tau):
    """tau[iv] += -k (q[iq] - ref) - c v[iv]."""
    tau[iv] += -k * (q[iq] - ref) - c * v[iv]


class JointSpring(ForceElement):
    """Linear spring-damper on one 1-dof joint (immutable)."""

    def __init__(self, name, idx_q, idx_v, k, c=0.0, reference=0.0):
        self.name, self.idx_q, self.idx_v = name, int(idx_q), int(idx_v)
        self.k, self.c, self.reference = float(k), float(c), float(reference)
        self.conservative = self.c == 0.0
        self._freeze()

    def create_data(self, mech):
        return None

    def force_kernel(self, mech, ws, d, z, zdot):
        return joint_spring_force, (self.idx_q, self.idx_v, self.k, self.c, self.reference, ws.q, ws.v, ws.tau)

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        joint_spring_force(self.idx_q, self.idx_v, self.k, self.c, self.reference, np.asarray(q, float),
                           np.asarray(v, float), tau)

    def potential(self, mech, ws, d, q):
        return 0.5 * self.k * (q[self.idx_q] - self.reference) ** 2

    def power_loss(self, mech, ws, d, t, q, v, z):
        return self.c * v[self.idx_v] ** 2

    def outputs(self, mech, ws, d, t, q, v, z):
        return {"torque": np.array(-self.k * (q[self.idx_q] - self.reference) - self.c * v[self.idx_v])}

    def describe(self):
        return {"name": self.name, "type": "joint_spring", "k": self.k, "c": self.c, "reference": self.reference}


def parse_joint_spring(f, ctx):
    """A ``joint_spring`` entry (keys checked) -> JointSpring (k, c >= 0); ``ctx``:
    pinclear.io.sidecar.Context."""
    from pinclear.core.values import number as _number

    jm = ctx.joint(f["joint"], "joint", one_dof=True)
    v = JOINT_SPRING.value
    k = _number(v(f, "k"), ctx.file, f"{ctx.key}.k")
    c = _number(v(f, "c"), ctx.file, f"{ctx.key}.c")
    if k < 0 or c < 0:
        raise ctx.error("", f"k = {k}, c = {c}: a spring's stiffness and damping are >= 0")
    return JointSpring(ctx.name, jm.idx_q, jm.idx_v, k, c, _number(v(f, "reference"), ctx.file,
                                                                      f"{ctx.key}.reference"))


JOINT_SPRING = PluginType(
    "joint_spring", parse=parse_joint_spring,
    doc="Linear spring and damper on a 1-DoF joint (joint_spring.JointSpring): an SDF joint's <dynamics>, an "
        "MJCF joint's stiffness / damping (pinclear import).",
    keys=(Key("joint", "joint name", range="a 1-DoF joint of the URDF", doc="the joint it acts on"),
          Key("k", "number", "N m/rad or N/m", 0.0, ">= 0", "tau = -k (q - reference) - c v", "stiffness"),
          Key("c", "number", "N m s/rad or N s/m", 0.0, ">= 0", "tau = -k (q - reference) - c v", "damping"),
          Key("reference", "number", "rad or m", 0.0, "finite", "tau = -k (q - reference) - c v",
              "the spring's rest coordinate")))
