"""A spring and damper on a 1-dof joint: tau = -k (q - reference) - c v (an SDF joint's
<dynamics> spring_stiffness, spring_reference and damping; an MJCF joint's stiffness, springref
and damping). Sidecar form::

    - {name: knee.spring, type: joint_spring, joint: knee, k: 1500.0, c: 0.1, reference: 0.0}

Potential 1/2 k (q - reference)^2, power loss c v^2 (the energy audit, pinclear.energy);
conservative when c = 0. Compiled (ForceElement contract 10): :func:`joint_spring_force`.
"""
from __future__ import annotations

import numpy as np

from ._jit import njit
from .errors import ModelFileError
from .forces import ForceElement


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


def joint_spring(model, spec, name, file, key):
    """The JointSpring of a sidecar ``type: joint_spring`` entry (k, c >= 0)."""
    from .sidecar import _joint, _number

    if "joint" not in spec:
        raise ModelFileError(file, f"{key}.joint", "missing")
    jm = _joint(model, spec["joint"], file, f"{key}.joint", one_dof=True)
    k = _number(spec.get("k", 0.0), file, f"{key}.k")
    c = _number(spec.get("c", 0.0), file, f"{key}.c")
    if k < 0 or c < 0:
        raise ModelFileError(file, key, f"k = {k}, c = {c}: a spring's stiffness and damping are >= 0")
    return JointSpring(name, jm.idx_q, jm.idx_v, k, c, _number(spec.get("reference", 0.0), file, f"{key}.reference"))
