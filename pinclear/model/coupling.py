"""The linear coupling closure: q(joint2) = ratio q(joint1) + offset between two 1-dof joints.

One row, linear in the joint coordinates: Phi = q2 - ratio q1 - offset, J = e2 - ratio e1
(constant), dJ v = 0. What it models: an SDF gearbox (theta2 = -gearbox_ratio theta1,
pinclear.io.importers.sdf), an MJCF joint equality of degree one, a URDF ``<mimic>`` (joint =
multiplier mimic_joint + offset). Sidecar form::

    - {name: knee_gear, type: coupling, joint1: knee_motor, joint2: knee, ratio: -0.0625, offset: 0.0}

The row joins the compiled closure table (pinclear.model.closures) as the primitive ``couple``: its two
frames are the joints' child bodies (so the row's support, pinclear.model.kinematics.row_support, holds
both joints and their ancestors), the table's last two columns the joints' v indices, and the
primitive's E block (ratio, offset) and the q indices.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.jit import njit
from pinclear.core.registry import Key, key_names

#: the keys of a coupling closure besides name and type (no frames)
COUPLING_KEYS = (
    Key("joint1", "joint name", range="a 1-DoF joint (coupling)", doc="the driving joint (coupling)"),
    Key("joint2", "joint name", range="another 1-DoF joint (coupling)", doc="the coupled joint (coupling)"),
    Key("ratio", "number", "-", range="finite (coupling: required)", source="coupling.py: q2 = ratio q1 + offset",
        doc="q(joint2) = ratio q(joint1) + offset (coupling)"),
    Key("offset", "number", "rad or m", 0.0, "finite", "coupling.py: q2 = ratio q1 + offset", "(coupling)"))
#: sidecar keys of a coupling closure
KEYS = {"name", "type"} | key_names(COUPLING_KEYS)


def table_entry(c):
    """(a, b, E block) of the closure table for a coupling Closure."""
    iq1, iv1, iq2, iv2, ratio, offset = c.coupling
    return (iv1, iv2), np.array([[ratio, offset, 0.0], [iq1, iq2, 0.0]])


@njit(cache=True, inline="always")
def coupling_positions(table, E, q, phi, Jc, dphi, code):
    """Phi = q2 - ratio q1 - offset and its constant J row for every coupling primitive."""
    nv = Jc.shape[1]
    for p in range(table.shape[0]):
        if table[p, 0] != code:
            continue
        r, iv1, iv2 = table[p, 3], table[p, 4], table[p, 5]
        ratio, offset = E[p, 0, 0], E[p, 0, 1]
        iq1, iq2 = int(E[p, 1, 0]), int(E[p, 1, 1])
        phi[r] = q[iq2] - ratio * q[iq1] - offset
        dphi[r] = 0.0
        for k in range(nv):
            Jc[r, k] = 0.0
        Jc[r, iv2] = 1.0
        Jc[r, iv1] -= ratio


@njit(cache=True, inline="always")
def coupling_velocities(table, E, v, dphi, bias, code):
    """J v of every coupling row; its bias dJ v is zero (J is constant)."""
    for p in range(table.shape[0]):
        if table[p, 0] != code:
            continue
        r, iv1, iv2 = table[p, 3], table[p, 4], table[p, 5]
        dphi[r] = v[iv2] - E[p, 0, 0] * v[iv1]
        bias[r] = 0.0
