"""Chains of three concurrent revolute joints (a spherical joint written as URDF needs it) and
their distance to the lock.

A URDF has no spherical joint: it is written as three revolute joints whose axes meet at one
point (pinclear.io.builder does it with two massless links). The chain's angular velocity is
w = a1 qd1 + a2 qd2 + a3 qd3 (the axes in world), so it loses a freedom where a1, a2, a3 become
coplanar (the lock: for the builder's chain, whose axes are pairwise perpendicular at the home
pose, the first and the last axis align). The distance to the lock is the angle between a3 and
the plane of a1 and a2: arcsin |a3 . (a1 x a2)/|a1 x a2||, 90 deg at best, 0 at the lock. With
a1 perpendicular to a2 and a2 perpendicular to a3 (which the chain keeps: each axis is fixed in
the body the previous one turns) it equals 90 deg - |q2| for q2 in (-90, 90) deg.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

_AT_ONE_POINT = 1e-12      # m: a joint origin this close to its parent's lies at the same point


def _is_revolute(model, data, j) -> bool:
    """A one-freedom joint whose motion is a pure rotation about an axis through its origin."""
    jm = model.joints[j]
    if jm.nv != 1:
        return False
    S = np.asarray(pin.getJointJacobian(model, data, j, pin.ReferenceFrame.LOCAL))[:, jm.idx_v]
    return float(np.linalg.norm(S[3:])) > 0.5 and float(np.linalg.norm(S[:3])) < 1e-9


def spherical_chains(model: pin.Model) -> list[tuple[int, int, int]]:
    """Joint ids (j1, j2, j3) of every chain of three revolute joints, each the parent of the
    next, whose axes meet at one point (j2 and j3 placed at their parent's joint origin)."""
    data = model.createData()
    q = pin.neutral(model)
    pin.computeJointJacobians(model, data, q)
    rev = {j for j in range(1, model.njoints) if _is_revolute(model, data, j)}
    chains = []
    for j3 in sorted(rev):
        j2 = model.parents[j3]
        j1 = model.parents[j2] if j2 > 0 else 0
        if j2 in rev and j1 in rev and all(
                np.linalg.norm(model.jointPlacements[j].translation) < _AT_ONE_POINT for j in (j2, j3)):
            chains.append((j1, j2, j3))
    return chains


def chain_label(model, chain) -> str:
    """'S1' for the builder's S1_1, S1_2, S1_3 (their common stem), else the three names."""
    names = [model.names[j] for j in chain]
    stem = names[0]
    while stem and not all(n.startswith(stem) for n in names):
        stem = stem[:-1]
    stem = stem.rstrip("_")
    return stem if stem else "-".join(names)


def lock_margins(model: pin.Model, q, chains=None, data=None) -> dict[str, float]:
    """{chain label: distance to the lock [rad]} at configuration ``q`` (module docstring)."""
    chains = spherical_chains(model) if chains is None else chains
    if not chains:
        return {}
    data = model.createData() if data is None else data
    pin.computeJointJacobians(model, data, np.asarray(q, float))
    out = {}
    for chain in chains:
        a = [np.asarray(pin.getJointJacobian(model, data, j, pin.ReferenceFrame.WORLD))[3:, model.joints[j].idx_v]
             for j in chain]
        a = [x / np.linalg.norm(x) for x in a]
        n = np.cross(a[0], a[1])
        nn = float(np.linalg.norm(n))
        out[chain_label(model, chain)] = 0.0 if nn < 1e-15 else float(np.arcsin(min(1.0, abs(a[2] @ n) / nn)))
    return out
